"""Files and run folders: bad-input errors, atomic writes, run folders, provenance, reference data, progress bars."""
