"""Tests of the continuum engine."""
