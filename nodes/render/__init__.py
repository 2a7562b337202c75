"""CPU rendering of cameras, depth cameras, 3-D lidars and 2-D lasers by ray casting (Embree), no GPU needed."""
