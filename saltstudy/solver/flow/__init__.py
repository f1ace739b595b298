"""The air: advection, pressure, diffusion, the wall, the drive and the time step."""
