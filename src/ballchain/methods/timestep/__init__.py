"""Moreau-Jean time-stepping: ``stepper`` (the compiled step and loop), ``driver`` (a run)."""
