"""The swarm family: PSO, MPSO, IPSO and their shared machinery (core, operators, backend,
refine, signatures, samples, roadmap; IPSO's ga and endgame)."""
