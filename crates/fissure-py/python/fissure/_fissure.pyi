"""Type stubs of the compiled module (checked by `python -m mypy.stubtest fissure._fissure`)."""

import os
from typing import Any, ClassVar, Sequence, final

import numpy as np
import numpy.typing as npt

__version__: str
__all__ = ["DampingModel", "Integrator", "Mesh", "Model", "ModelBuilder", "Solver", "State", "World", "__version__", "load_scene", "run_many", "_model_from_pickle", "_state_from_pickle", "_world_from_pickle"]

_Vec3 = tuple[float, float, float]

@final
class Integrator:
    """The time integrators (a closed set; compare with ==, convert with int())."""

    SYMPLECTIC_EULER: ClassVar[Integrator]
    VELOCITY_VERLET: ClassVar[Integrator]
    RK4: ClassVar[Integrator]
    IMPLICIT_EULER: ClassVar[Integrator]
    @property
    def order(self) -> int: ...
    def __int__(self) -> int: ...

@final
class DampingModel:
    """The two damping forms of the seed's eq. (2)."""

    PROJECTED: ClassVar[DampingModel]
    UNPROJECTED: ClassVar[DampingModel]
    def __int__(self) -> int: ...

@final
class Mesh:
    def __new__(cls, positions: npt.ArrayLike, triangles: npt.ArrayLike) -> Mesh: ...
    @staticmethod
    def icosphere(radius: float, subdivisions: int) -> Mesh: ...
    @staticmethod
    def grid(nx: int, ny: int, spacing: float) -> Mesh: ...
    @staticmethod
    def cuboid(half_extents: _Vec3, n: int = 1) -> Mesh: ...
    @staticmethod
    def load_obj(path: str | os.PathLike[str], *, weld_tolerance: float | None = None) -> Mesh: ...
    def save_obj(self, path: str | os.PathLike[str]) -> None: ...
    def save_ply(self, path: str | os.PathLike[str]) -> None: ...
    def translated(self, offset: _Vec3) -> Mesh: ...
    def renumbered_for_locality(self) -> tuple[Mesh, npt.NDArray[np.uint32], npt.NDArray[np.uint32]]: ...
    @property
    def positions(self) -> npt.NDArray[np.float64]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    def is_closed(self) -> bool: ...
    def signed_volume(self) -> float: ...
    def area(self) -> float: ...

@final
class ModelBuilder:
    def __new__(cls, *, gravity: _Vec3 = ..., damping_model: DampingModel = ...) -> ModelBuilder: ...
    def add_particle(self, position: _Vec3, velocity: _Vec3 = ..., *, mass: float) -> int: ...
    def add_spring(self, i: int, j: int, *, stiffness: float, damping: float = 0.0) -> int: ...
    def add_soft_body(
        self,
        mesh: Mesh,
        *,
        mass: float | None = None,
        area_density: float | None = None,
        particle_mass: float | None = None,
        stiffness: float | None = None,
        spring_stiffness: float | None = None,
        damping_ratio: float | None = None,
        spring_damping: float | None = None,
        bending: float | None = None,
        pressure: float | None = None,
        gas_amount: float | None = None,
        external_pressure: float = 0.0,
        velocity: _Vec3 = ...,
        drag: float = 0.0,
        lift: float = 0.0,
        reorient: bool = True,
        strain_limit: float | None = None,
        load_limit: float | None = None,
        sealed: bool = False,
        tear_strength: float | None = None,
        gas_inflow: float = 0.0,
    ) -> dict[str, int]: ...
    def add_cloth(
        self,
        mesh: Mesh,
        *,
        mass: float | None = None,
        area_density: float | None = None,
        particle_mass: float | None = None,
        stiffness: float | None = None,
        spring_stiffness: float | None = None,
        bending: float | None = None,
        damping_ratio: float | None = None,
        spring_damping: float | None = None,
        pins: Sequence[int] = ...,
        drag: float = 1.0,
        lift: float = 0.5,
        strain_limit: float | None = None,
        load_limit: float | None = None,
        tear_strength: float | None = None,
    ) -> dict[str, int]: ...
    def add_cloth_grid(
        self,
        nx: int,
        ny: int,
        spacing: float,
        *,
        origin: _Vec3 = ...,
        down: _Vec3 = ...,
        mass: float | None = None,
        area_density: float | None = None,
        particle_mass: float | None = None,
        spring_stiffness: float = 1000.0,
        shear: float = 1000.0,
        bending: float = 1000.0,
        damping_ratio: float | None = None,
        spring_damping: float | None = None,
        pins: Sequence[int] = ...,
        drag: float = 1.0,
        lift: float = 0.5,
        strain_limit: float | None = None,
        load_limit: float | None = None,
        tear_strength: float | None = None,
    ) -> dict[str, int]: ...
    def add_handle(
        self,
        particles: Sequence[int],
        *,
        velocity: _Vec3 | None = None,
        start: float = 0.0,
        stop: float | None = None,
        path: Sequence[tuple[float, _Vec3]] | None = None,
    ) -> int: ...
    def set_contact(
        self, body: int, *, thickness: float | None = None, self_collision: bool = False, friction: float = 0.3
    ) -> None: ...
    def add_ground(
        self, height: float = 0.0, *, restitution: float = 0.3, friction: float = 0.4, margin: float = 0.0
    ) -> None: ...
    def add_plane(
        self, point: _Vec3, normal: _Vec3, *, restitution: float = 0.3, friction: float = 0.4, margin: float = 0.0
    ) -> None: ...
    def add_ball(
        self,
        center: _Vec3,
        radius: float,
        *,
        velocity: _Vec3 = ...,
        restitution: float = 0.3,
        friction: float = 0.4,
        margin: float = 0.0,
    ) -> None: ...
    def add_cuboid(
        self, center: _Vec3, half_extents: _Vec3, *, restitution: float = 0.3, friction: float = 0.4, margin: float = 0.0
    ) -> None: ...
    def add_capsule(
        self, a: _Vec3, b: _Vec3, radius: float, *, restitution: float = 0.3, friction: float = 0.4, margin: float = 0.0
    ) -> None: ...
    def add_mesh_collider(
        self, mesh: Mesh, *, restitution: float = 0.3, friction: float = 0.4, margin: float = 0.0
    ) -> None: ...
    def set_wind(
        self,
        velocity: _Vec3,
        *,
        gust_amplitude: float = 0.5,
        gust_frequency: float = 0.5,
        gust_wavelength: float = 4.0,
        crosswind: float = 0.2,
        air_density: float = 1.225,
    ) -> None: ...
    @property
    def particle_count(self) -> int: ...
    def finalize(self, *, precision: str = "float32") -> Model: ...

@final
class Model:
    def __reduce__(self) -> tuple[Any, ...]: ...
    def state(self) -> State: ...
    @property
    def precision(self) -> str: ...
    @property
    def particle_count(self) -> int: ...
    @property
    def spring_count(self) -> int: ...
    @property
    def tri_count(self) -> int: ...
    @property
    def body_count(self) -> int: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def springs(self) -> npt.NDArray[np.uint32]: ...
    def total_mass(self) -> float: ...
    def body_volumes(self, state: State) -> list[float]: ...
    def body_pressures(self, state: State) -> list[float]: ...
    def momentum(self, state: State) -> _Vec3: ...
    def center_of_mass(self, state: State) -> _Vec3: ...
    def energy(self, state: State) -> dict[str, float]: ...

@final
class State:
    def __reduce__(self) -> tuple[Any, ...]: ...
    @property
    def positions(self) -> npt.NDArray[np.floating[Any]]: ...
    @positions.setter
    def positions(self, value: npt.ArrayLike) -> None: ...
    @property
    def velocities(self) -> npt.NDArray[np.floating[Any]]: ...
    @velocities.setter
    def velocities(self, value: npt.ArrayLike) -> None: ...
    @property
    def time(self) -> float: ...
    @property
    def particle_count(self) -> int: ...
    @property
    def precision(self) -> str: ...
    def copy_positions_into(self, out: npt.NDArray[np.floating[Any]]) -> None: ...
    def copy_velocities_into(self, out: npt.NDArray[np.floating[Any]]) -> None: ...
    def copy(self) -> State: ...

@final
class Solver:
    def __new__(
        cls,
        *,
        integrator: Integrator = ...,
        cg_tolerance: float = 1e-5,
        cg_max_iterations: int = 200,
        cg_coarse: bool = True,
        substep_safety: float | None = None,
    ) -> Solver: ...
    def step(self, model: Model, state: State, dt: float, steps: int = 1) -> None: ...
    def timers(self) -> dict[str, Any]: ...
    def contact_stats(self) -> dict[str, int]: ...

@final
class World:
    def __reduce__(self) -> tuple[Any, ...]: ...
    def __new__(
        cls,
        model: Model,
        *,
        integrator: Integrator = ...,
        cg_tolerance: float = 1e-5,
        cg_max_iterations: int = 200,
        cg_coarse: bool = True,
        substep_safety: float | None = None,
        max_events_per_step: int = 32,
        averaged_window: float | None = None,
        discharge_coefficient: float = 0.6,
        gas_density: float = 1.2,
        start_time: float = 0.0,
        splits_per_body: int = 1,
        nucleation_interval: float | None = None,
    ) -> World: ...
    @property
    def model(self) -> Model: ...
    @property
    def state(self) -> State: ...
    @property
    def solver(self) -> Solver: ...
    @property
    def time(self) -> float: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    def step(self, dt: float, steps: int = 1) -> int: ...
    def advance(self, duration: float, dt: float) -> int: ...
    def rest(self) -> None: ...
    def break_spring(self, index: int) -> list[dict[str, Any]]: ...
    def break_core(self, index: int) -> list[dict[str, Any]]: ...
    def save_vtk(self, path: str | os.PathLike[str]) -> None: ...
    def timers(self) -> dict[str, Any]: ...

def load_scene(
    path: str | os.PathLike[str], overrides: dict[str, Any] | None = None, *, precision: str = "float32"
) -> dict[str, Any]: ...
def run_many(
    runs: Sequence[Any],
    overrides: dict[str, Any] | None = None,
    *,
    duration: float | None = None,
    dt: float | None = None,
    threads: int | None = None,
    precision: str = "float32",
) -> dict[str, Any]: ...
def _model_from_pickle(bytes: bytes) -> Model: ...
def _state_from_pickle(bytes: bytes) -> State: ...
def _world_from_pickle(bytes: bytes) -> World: ...
