//! Monte Carlo photon-packet transport in layered media (Prahl et al. 1989; MCML).
