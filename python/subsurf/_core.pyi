# Type stubs of the extension module subsurf._core (one section per binding module).

# --- mc ---
def mc_validate_source(kind: str, theta: float, phi: float) -> None: ...
def mc_simulate(
    layers: list[tuple[float, float, float, list[tuple[float, float]], float]],
    n_above: float,
    n_below: float,
    photons: int,
    seed: int,
    threads: int | None,
    source: tuple[str, float, float],
    progress: object | None = None,
) -> dict: ...
