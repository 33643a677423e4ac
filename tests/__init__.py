"""Tests of colony-mechanics, by package: continuum/, particles/, cases/; docs at the top."""
