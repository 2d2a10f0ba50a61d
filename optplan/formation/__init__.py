"""The formation family: the piloted base, leader-follower (L-phi), the per-step QP."""
