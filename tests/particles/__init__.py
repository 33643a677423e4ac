"""Tests of the particle engine."""
