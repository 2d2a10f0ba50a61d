"""Tests of optplan's geometry part."""
