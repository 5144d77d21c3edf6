"""Execution on a controller: EGM streaming (execute), the virtual IRC5 (virtual-robot), its drives."""
