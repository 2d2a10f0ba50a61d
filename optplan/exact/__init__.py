"""Exact references: the certified shortest path and the waypoint NLP."""
