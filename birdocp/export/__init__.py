"""Export of the model as C code, and the compiled right-hand side that the solvers can use."""
