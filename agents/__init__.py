"""Everything that decides: optimisers, reference policies, RL agents, the CLI."""
