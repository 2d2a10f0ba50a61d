"""Tests of optplan's exact part."""
