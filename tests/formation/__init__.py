"""Tests of optplan's formation part."""
