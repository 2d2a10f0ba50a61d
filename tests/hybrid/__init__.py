"""Tests of optplan's hybrid part."""
