"""Declared capabilities of the stages a composite planner is built from.

A *stage* is a solver used inside another one: the hybrid planner's global path solver, local
planner and formation backend (:class:`~optplan.hybrid.planner.Hybrid`), a formation
backend's leader pilot and reference path solver
(:class:`~optplan.formation.pilot.PilotedFormation`).  What a stage must provide is
declared here as :class:`typing.Protocol` classes (``runtime_checkable``, so ``isinstance``
checks the methods and attributes are there; subclassing them is optional and only documents
the intent), and :func:`resolve_stage` turns a stage option into a backend object when the
solver is built, so a misspelled name or a backend of the wrong kind is a ``ValueError`` from
``get_solver`` naming the option, never an ``AttributeError`` in the middle of a run.

Protocols
---------
:class:`LocalPlanner`
    A backend with ``controller(problem, robot_id, rng)`` returning a
    :class:`LocalController`: drives one robot toward a (sub-)goal, one simulator step at a time
    (``apf``, ``sa-apf``).
:class:`FormationBackend`
    A backend with ``followers_controller(problem, rng)`` returning a
    :class:`FollowerController`: velocities of a formation's followers around a leader that
    someone else drives (``leader-follower``, ``formation-qp``).

Both declare ``stats_units``, the units of their controllers' ``stats``
(:mod:`optplan.units`).

Both controllers are called from inside :func:`optplan.sim.simulate` with the simulator's
:class:`~optplan.sim.SimState`: ``state.dt`` is the time step, ``state.positions`` the robots'
positions (rows in ``state.ids`` order), ``state.field`` the sensed obstacles, and, for a
follower controller, ``state.leader_velocity`` the leader's command of the current step.
Randomness comes only from the ``rng`` a controller was built with.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from optplan.problem import Problem
    from optplan.sim import SimState
    from optplan.solver import Backend
    from optplan.units import Record

__all__ = [
    "LocalController",
    "LocalPlanner",
    "FollowerController",
    "FormationBackend",
    "StageKind",
    "PATH_SOLVER",
    "LOCAL_PLANNER",
    "FORMATION_BACKEND",
    "resolve_stage",
    "stage_name",
]


# --------------------------------------------------------------------------------------
# the protocols
# --------------------------------------------------------------------------------------


@runtime_checkable
class LocalController(Protocol):
    """Drives one robot toward its current goal, one simulator step at a time.

    Attributes
    ----------
    stats : dict
        Counters of the controller (JSON-serialisable values); copied into the caller's
        ``Result.extras`` (e.g. ``extras["local_stats"]`` of the hybrid planner).
    """

    stats: dict[str, Any]

    def reset(self, goal: np.ndarray) -> None:
        """Set a new goal ``(2,)`` (a sub-goal of a longer route, or the final goal).

        Called once before the first :meth:`velocity` and again whenever the caller moves on
        to the next sub-goal; the controller forgets what was specific to the old goal (e.g.
        detected local minima).
        """
        ...

    def velocity(self, state: SimState, index: int) -> np.ndarray | None:
        """The desired velocity ``(2,)`` (map units per second) of robot ``state.ids[index]``.

        Parameters
        ----------
        state : SimState
            The simulator's state; the robot is at ``state.positions[index]``, the step is
            ``state.dt`` and the sensed obstacles are ``state.field``.
        index : int
            Row of the robot in ``state.positions``.

        Returns
        -------
        array ``(2,)`` or None
            The command (the simulator clamps its norm to the robot's ``max_speed``), or
            ``None`` when the controller gives up on the current goal (the caller decides
            what happens next: the hybrid planner skips an intermediate sub-goal and ends the
            run at the final goal).
        """
        ...


@runtime_checkable
class LocalPlanner(Protocol):
    """A backend that can drive one robot inside someone else's simulation.

    Implemented by :class:`~optplan.potential.apf.APF` and
    :class:`~optplan.potential.sa_apf.SAAPF`; required of the hybrid planner's
    ``local_solver`` and of a formation backend's ``pilot``.

    Attributes
    ----------
    stats_units : Record
        The units of its controllers' ``stats`` (:mod:`optplan.units`), every key declared:
        the caller reports them in its extras, and the hybrid planner maps them back from its
        canonical frame by them (an undeclared key raises
        :class:`~optplan.units.UndeclaredUnit`).
    """

    @property
    def stats_units(self) -> Record: ...

    def controller(self, problem: Problem, robot_id: str,
                   rng: np.random.Generator) -> LocalController:
        """A fresh :class:`LocalController` for robot ``robot_id`` of ``problem``.

        Parameters
        ----------
        problem : Problem
            The full problem (the controller senses through ``state.field``, not through a
            view of the known map).
        robot_id : str
            The robot to drive; its radius and ``max_speed`` are read from ``problem``.
        rng : numpy.random.Generator
            The only source of randomness of the controller.
        """
        ...


@runtime_checkable
class FollowerController(Protocol):
    """Velocities of a formation's followers, given the leader that someone else drives.

    Attributes
    ----------
    stats : dict
        Counters of the controller (JSON-serialisable values), copied into the caller's
        ``Result.extras`` (``extras["formation_stats"]`` of the hybrid planner).
    """

    stats: dict[str, Any]

    def velocities(self, state: SimState, leader_index: int, follower_indices: list[int],
                   leader_heading: float) -> np.ndarray:
        """Commands ``(F, 2)`` of the followers at rows ``follower_indices`` of the state.

        Parameters
        ----------
        state : SimState
            The simulator's state.  ``state.leader_velocity`` is the leader's command for
            this step when the caller set it (use :meth:`SimState.leader_command
            <optplan.sim.SimState.leader_command>`, which falls back to the leader's previous
            velocity).
        leader_index : int
            Row of the leader in ``state.positions``.
        follower_indices : list of int
            Rows of the followers, in the order of ``problem.formation.followers``.
        leader_heading : float
            Heading (rad) of the formation frame; the L-phi slots are placed around the leader
            with it (:meth:`optplan.problem.Formation.slot_offsets`).

        Returns
        -------
        array ``(F, 2)``
            Finite commands (the simulator clamps each to the follower's ``max_speed``).
        """
        ...


@runtime_checkable
class FormationBackend(Protocol):
    """A backend whose follower law can run around a leader driven by another planner.

    Implemented by :class:`~optplan.formation.leader_follower.LeaderFollower` and
    :class:`~optplan.formation.formation_qp.FormationQP`; required of the hybrid planner's
    ``formation`` option.

    Attributes
    ----------
    stats_units : Record
        The units of its follower controller's ``stats`` (:mod:`optplan.units`), every key
        declared (as for :class:`LocalPlanner`).
    """

    @property
    def stats_units(self) -> Record: ...

    def followers_controller(self, problem: Problem,
                             rng: np.random.Generator) -> FollowerController:
        """A fresh :class:`FollowerController` for the followers of ``problem.formation``.

        Raises
        ------
        ValueError
            If ``problem`` has no ``[formation]``.
        """
        ...


# --------------------------------------------------------------------------------------
# resolving stage options when a solver is built
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StageKind:
    """What a stage option must name.

    Attributes
    ----------
    label : str
        Name of the kind in messages (``"local planner"``).
    protocol : type or None
        The protocol the backend must satisfy (``None``: any backend).
    method : str
        The method the protocol requires, shown in messages and used to classify backend
        classes without building them.
    attributes : tuple of str
        The attributes the protocol requires besides ``method`` (named in messages).
    """

    label: str
    protocol: type | None = None
    method: str = ""
    attributes: tuple[str, ...] = ()

    def accepts_class(self, cls: type) -> bool:
        return not self.method or callable(getattr(cls, self.method, None))

    def accepts(self, obj: Any) -> bool:
        return self.protocol is None or isinstance(obj, self.protocol)

    def missing(self, obj: Any) -> str:
        """What ``obj`` lacks of the protocol, for messages: the method (``"controller()"``),
        else the attributes (``"stats_units"``)."""
        if not callable(getattr(obj, self.method, None)):
            return f"{self.method}()"
        return " and ".join(a for a in self.attributes if not hasattr(obj, a)) or "?"

    def describe(self) -> str:
        if self.protocol is None:
            return f"a {self.label} (any preset or backend name)"
        return (f"a {self.label} (a preset or backend with {self.method}(), "
                f"optplan.interfaces.{self.protocol.__name__})")


#: Any backend: every backend returns paths from ``solve``.
PATH_SOLVER = StageKind("path solver")
#: A :class:`LocalPlanner`.
LOCAL_PLANNER = StageKind("local planner", LocalPlanner, "controller", ("stats_units",))
#: A :class:`FormationBackend`.
FORMATION_BACKEND = StageKind("formation backend", FormationBackend, "followers_controller",
                              ("stats_units",))


def _backend_class_of(name: str) -> type | None:
    """The backend class a preset or backend name resolves to, or None if it cannot load."""
    from optplan.catalog import read_preset
    from optplan.solver import BACKENDS, _load_class, all_preset_files

    try:
        presets = all_preset_files()
        backend = read_preset(presets[name])["backend"] if name in presets else name
        if backend not in BACKENDS:
            return None
        return _load_class(backend)
    except (ImportError, ValueError, KeyError):
        return None


def _names_of_kind(kind: StageKind, names: list[str]) -> list[str]:
    out = []
    for n in names:
        cls = _backend_class_of(n)
        if cls is not None and kind.accepts_class(cls):
            out.append(n)
    return out


def _suggest(spec: str, kind: StageKind, exclude: str = "") -> str:
    """``"; did you mean 'a', 'b'?"`` among the names of ``kind`` close to ``spec``."""
    from optplan.solver import list_solvers

    names = [n for n in dict.fromkeys(list_solvers(backends=True)) if n != exclude]
    close = difflib.get_close_matches(spec, names, n=8, cutoff=0.5)
    close = _names_of_kind(kind, close)[:3]
    if not close:  # nothing close by spelling: the names of the right kind, by similarity
        close = difflib.get_close_matches(spec, _names_of_kind(kind, names), n=3, cutoff=0.0)
    return f"; did you mean {', '.join(repr(c) for c in close)}?" if close else ""


def resolve_stage(owner: str, option: str, spec: Any, kind: StageKind) -> Backend:
    """Build the backend a stage option names, checking that it is of the right kind.

    Parameters
    ----------
    owner : str
        Name of the backend whose option this is (for messages).
    option : str
        The option's name (for messages).
    spec : str or Backend
        A preset or backend name (what :func:`optplan.get_solver` accepts) or a backend object.
    kind : StageKind
        What the option must name (:data:`PATH_SOLVER`, :data:`LOCAL_PLANNER`,
        :data:`FORMATION_BACKEND`).

    Returns
    -------
    Backend
        The configured backend (a preset's options applied).

    Raises
    ------
    ValueError
        Naming the option, the expected kind and close matches, when ``spec`` is not a name or
        a backend, names no solver, names a solver of another kind, or names a preset whose
        own options are invalid.
    """
    from optplan.solver import Backend, get_solver

    where = f"option {option!r} of backend {owner!r}"
    if isinstance(spec, Backend):
        obj = spec
    elif isinstance(spec, str) and spec:
        try:
            obj = get_solver(spec)
        except ValueError as e:
            if str(e).startswith("unknown solver"):
                raise ValueError(f"{where} must be {kind.describe()}: no solver named "
                                 f"{spec!r}{_suggest(spec, kind)}") from None
            raise ValueError(f"{where}: {e}") from None
        except ImportError as e:
            raise ValueError(f"{where}: {e}") from None
    else:
        raise ValueError(f"{where} must be {kind.describe()}, got {spec!r}")
    if not kind.accepts(obj):
        what = f"{spec!r} (backend {obj.name!r})" if isinstance(spec, str) else (
            f"backend {obj.name!r}")
        hint = _suggest(spec, kind, exclude=spec) if isinstance(spec, str) else ""
        raise ValueError(f"{where} must be {kind.describe()}; {what} has no "
                         f"{kind.missing(obj)}{hint}")
    return obj


def stage_name(spec: Any) -> str:
    """The name a stage option is recorded under: a preset or backend name."""
    from optplan.solver import Backend

    if isinstance(spec, Backend):
        return spec.preset or spec.name
    return str(spec)
