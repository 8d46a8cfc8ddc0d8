"""Analysis: observables of trajectories and the linear stability of the aligned state."""
