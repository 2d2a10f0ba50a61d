"""Tests of optplan's core part."""
