"""The simulation loop and its result."""
