"""Tests of optplan's potential part."""
