"""The bird's studies: trim, level flight, sweeps, branches, sensitivities, optimisers, control, simulation, wing masses."""
