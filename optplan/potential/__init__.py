"""The potential-field family: APF (paper eqs 3-13) and SA-APF (eqs 34-38)."""
