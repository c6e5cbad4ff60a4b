"""How a command runs: cast threads, freed memory, signals, the cast clock, test pauses (numpy only)."""
