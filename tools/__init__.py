"""Developer tools of the Vergence repository (not installed with the package)."""
