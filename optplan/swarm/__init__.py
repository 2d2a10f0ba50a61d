"""The swarm family: encoding, fitness and operators (core), PSO, MPSO, IPSO."""
