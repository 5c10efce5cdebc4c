//! Diffusion models of subsurface scattering: Jensen et al. (2001) dipole, d'Eon (2012) better dipole.
