"""The bird: configuration, kinematics, wing, lifting line, tail, wing masses, the CasADi model, flight outputs, powers and validity."""
