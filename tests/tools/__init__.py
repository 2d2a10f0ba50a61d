"""Tests of optplan's tools part."""
