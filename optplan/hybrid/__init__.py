"""The paper's hybrid planner: global path, sub-goals, local planning, formation."""
