"""Tests of optplan's swarm part."""
