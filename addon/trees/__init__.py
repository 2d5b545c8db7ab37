"""Weber-Penn trees that sway in the shared wind (seed 001)."""
