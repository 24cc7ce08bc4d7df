"""The learned 6-DoF route sampler: the workspace route's positions with orientations from a learned model.

``RigidRouteSampler`` draws positions as the no-learning ablation does
(``planners.guidance.workspace_route.WorkspaceRouteSampler``: points at uniform arc length along the
exact workspace route of the body's centre plus Gaussian noise of the world's ``route_spread`` (a box
world's inner radius), a share of
uniform states), about the route pulled to the middle of its passages (``centre_route``, ``centre``
voxels), and replaces its uniform angles by the orientation model's
(``learning.models.rigid_orientation.OrientationNet``). Per query, once: the route, its centring, the
model's observation at every route point (``planners.guidance.rigid_orientation.route_observation``)
and its distribution over the six axis-aligned orientation classes there. Per sample, numpy (where the route
samples follow the trees, ``follow``, one compiled call per draw: ``planners.guidance.route_draws``):

* with probability ``goal_share`` the goal state;
* else with probability ``route_fraction`` a route sample: its position as the ablation draws it; its orientation,
  with probability ``uniform_share`` (rising to 1 over a tree's first ``uniform_ramp`` samples of the query), where
  the model's largest class probability at the nearest route point is below ``min_confidence``, or everywhere when
  its largest over the whole route is below ``min_route_confidence`` (a query whose passages the model does not see
  as needing a turn), uniform angles, else a class drawn from the
  model's distribution there, one of the class's four rotations (the box's symmetry: the same volume, far apart in
  the planner's metric) at random (``symmetry="random"``), the one nearest the orientation of the query's end
  nearer the sample's route point (``symmetry="ends"``: the start's or the goal's; the trees' rule), or the one
  nearest a chain of rotations walked along the route (``rotation_chain``: from the start all along,
  ``symmetry="chain_start"``, the roadmaps' rule, with every route sample on the route; ``for_planner``; or from
  both ends, ``"chain"``), turned by a random rotation of about ``angle_noise`` radians per axis (a Gaussian
  rotation vector);
* else a uniform state (a tree on a mesh world: ``route_fraction`` rises to its own from the roadmap's over the
  ``uniform_ramp``, ``TREES_KEEP``).

Samples do not depend on the tree, so they come in batches. The orientation model learned on a box body
among boxes (``RigidBodyWorld``); in a mesh world (``MeshWorld``) the classes carry over to the body by
its own long, middle and short axes (``body_axes``), the model sees voxels of the body's long side over
``TRAINING_LONG_SIDE`` (so the body spans as many voxels as the training body did), and the occupancy is
the world's ``solid_share`` (its surfaces and what they enclose, seen from the query's start and goal).
"""

from __future__ import annotations

import copy

import numpy as np

from planners.base.fileio import InputError, check_int, check_number
from planners.base.samplers import FAMILY_ROADMAP, SamplerBase
from planners.guidance.rigid_orientation import (
    N_CLASSES,
    PATCH_HALF,
    TRAINING_LONG_SIDE,
    body_axes,
    class_rotations,
    euler_from_matrices,
    nearer_end,
    route_observation,
    small_rotations,
)
from planners.guidance.route_draws import follow_draw, watch_reach
from planners.guidance.workspace_route import box_muller, centre_route, route_world, voxel_route
from planners.worlds.mesh import rotation_matrices

#: The settings ``make_sampler("rigid_route")`` uses: chosen on the tuning scenes
#: (``scripts/experiments/tune_rigid_learned.py``; the rotation among a class's four by
#: ``scripts/experiments/rigid_room.py --part tuning``, with the privileged expert's classes; ``docs/rigid-scenes.md``).
#: The route positions crowd where the route is tight (``passage_weight``), as a roadmap's do: chosen for the trees
#: on the tuning scenes and kept on validation scenes no rule had looked at. The route samples follow the trees
#: (``follow`` 2 body radii): chosen on the tuning scenes' time and kept on the validation scenes' (the draws compiled).
SHIPPED_RIGID_SETTINGS = {"uniform_share": 0.1, "angle_noise": 0.1, "centre": 2, "symmetry": "ends",
                          "min_confidence": 0.0, "min_route_confidence": 0.0, "route_fraction": 0.75,
                          "passage_weight": 16.0, "uniform_ramp": 0.0, "uniform_first": 0.0, "stall_window": 0.0,
                          "follow": 2.0, "follow_share": 1.0}
#: What a roadmap planner takes instead (``RigidRouteSampler.for_planner``): every route sample on the route, each
#: in the model's class (no uniform angles) at the rotation of the chain walked from the start all along the route
#: (where walks from both ends meet, in a passage, two rotations a half turn apart may leave the roadmap in two
#: parts), unturned; chosen for PRM on the tuning scenes, kept by the validation scenes (``docs/rigid-scenes.md``).
#: On box worlds the trees keep ``SHIPPED_RIGID_SETTINGS``' (the chain lost on the tuning scenes, a smaller angle
#: noise on the validation scenes); on mesh worlds they take these too (``bind``: on the training families written as
#: meshes, tuning and validation parts, in 0.7 to 0.8 of the time; ``scripts/experiments/tree_rule_meshes.py``).
#: Route positions are drawn 1 + 16 times as densely where the route's patch is solid (``passage_weight``): more
#: samples in the passages, fewer in the open (PRM's tuning and validation scenes; the mesh trees' time too).
#: The trees on mesh worlds turn their route samples to uniform angles over their first 4,000 samples
#: (``uniform_ramp``; a roadmap drops it), and come to their own share of uniform states over it (``TREES_KEEP``):
#: on the twisted slot, a passage no class's rotation passes, they then solve
#: every tuning and validation run, and the training families as meshes, at the default step and at the seed
#: project's small one (where the classes take thousands of samples and a 1,000-sample ramp lost), take 0.97 to 1.01
#: of the time without the ramp. They compute the route at their first sample (``uniform_first`` 0): uniform states
#: first cost them 1.7 to 3.8 times the time on the training families as meshes (2,500 to 10,000 of them). The ramp
#: counts every route sample (``stall_window`` 0): clocked only while the trees stand still (1,000 samples), it took
#: RRT-Connect twice the time on the validation twisted slots. They draw the route samples along the whole route
#: (``follow`` 0): in windows about the trees' reach (4 body radii) they missed the training families' bar at the
#: default step (1.02 times the time) though the twisted slots took 0.66 of it. The trees on box worlds draw them in
#: windows of 2 body radii about the trees' reach (``follow``, in ``SHIPPED_RIGID_SETTINGS``): 0.61 of the tuning
#: part's iterations in 0.88 of the time, 0.80 and 0.96 on the validation part, with the draws compiled.
SHIPPED_RIGID_ROADMAP = {"symmetry": "chain_start", "route_fraction": 1.0, "uniform_share": 0.0, "angle_noise": 0.0,
                         "passage_weight": 16.0, "uniform_ramp": 4000.0, "uniform_first": 0.0,
                         "stall_window": 0.0, "follow": 0.0, "follow_share": 1.0}

_ROTATIONS = class_rotations()
#: ``RigidRouteSampler``'s ways to pick among a class's four rotations.
SYMMETRY_RULES = ("random", "ends", "chain", "chain_start")
#: The settings a roadmap may take apart from the trees' (``RigidRouteSampler``'s ``roadmap``).
ROADMAP_SETTINGS = ("symmetry", "route_fraction", "uniform_share", "angle_noise", "passage_weight", "uniform_ramp",
                    "uniform_first", "stall_window", "follow", "follow_share")
#: What the trees keep of their own settings where they take the roadmaps' (on a mesh world): their uniform states
#: (``route_fraction``: a roadmap draws every sample on the route, a tree a quarter of them uniformly), which with a
#: ``uniform_ramp`` come over the ramp, from the roadmap's none at the first sample to the tree's own share, so that a
#: query the classes do not solve soon comes to the ablation's samples, positions as well as angles. A tree held to
#: the workspace route by every sample stays where that route misleads the body: on OMPL.app's Apartment (a tuning
#: problem), at a mesh world's default step, RRT-Connect with every sample on the route solved 1 of 8 runs within 20 s,
#: with the floor over the ramp 6 (uniform sampling 7); on the training families as meshes and the twisted slot the
#: same runs solved in 0.80 to 1.11 of the time (tuning part) and 0.98 to 1.05 (validation part). A floor from the
#: first sample solved 6 of 8 too but took 1.18 and 1.30 of the time on the validation slots
#: (``scripts/experiments/tree_rule_meshes.py``; ``docs/rigid-scenes.md``, "The trees' floor").
TREES_KEEP = ("route_fraction",)
#: Most samples one draw returns where the draws follow the trees (``follow``): the window moves at least this often.
FOLLOW_BATCH = 64


def class_frame(world, cell: float | None = None) -> tuple[np.ndarray, float]:
    """The orientation classes' rotations in ``world`` (``(6, 4, 3, 3)``) and the voxel side the model sees there.

    A box world: the body the model learned on, seen at the route's voxels (``cell``, or the world's
    ``route_cell``). A mesh world: its body's own axes carry the classes (``body_axes``), and the model sees voxels
    of the body's long side over ``TRAINING_LONG_SIDE`` (or ``cell`` where given).
    """
    if hasattr(world, "boxes"):
        return _ROTATIONS, float(world.route_cell if cell is None else cell)
    axes, extents = body_axes(world.body_vertices)
    return _ROTATIONS @ axes.T, float(extents[0]) / TRAINING_LONG_SIDE if cell is None else float(cell)


def rotation_chain(rotations: np.ndarray, classes: np.ndarray, ends: np.ndarray, arc: np.ndarray,
                   start_only: bool = False) -> np.ndarray:
    """``(n, 3, 3)``: per route point, the one of its class's four rotations nearest the point before's.

    Walked from the start's orientation (``ends[0]``) forward and from the goal's (``ends[1]``) backward; each point
    takes the walk from the end nearer along the route (``arc``: its cumulative length), or (``start_only``) the walk
    from the start everywhere.
    """
    def walk(order, first):
        out, cur = np.empty((len(classes), 3, 3)), first
        for i in order:
            cand = rotations[classes[i]]
            cur = cand[np.einsum("sij,ij->s", cand, cur).argmax()]
            out[i] = cur
        return out

    forward = walk(range(len(classes)), ends[0])
    if start_only:
        return forward
    backward = walk(range(len(classes) - 1, -1, -1), ends[1])
    return np.where((arc <= arc[-1] / 2)[:, None, None], forward, backward)


class RigidRouteSampler(SamplerBase):
    """Route positions with learned orientations (see the module doc).

    Args:
        net: The orientation model (``load_orientation_net``); None with ``uniform_share`` 1: the sampler's own
            no-learning ablation (the same positions, uniform angles; ``make_sampler("rigid_route_ablation")``).
        route_fraction: Probability in [0, 1] of a route sample (the ablation's 0.75).
        uniform_share: Probability in [0, 1] that a route sample takes uniform angles instead of the model's.
        angle_noise: Standard deviation, radians, of each component of the rotation vector turning a
            class's orientation.
        goal_share: Probability in [0, 1] of drawing the goal state.
        temperature: Softmax temperature of the model's logits (> 0; below 1 sharpens).
        spread: Standard deviation of the position noise about the route; None: the world's ``route_spread``
            (a box world's inner radius).
        cell: Voxel side of the route search and of the model's observation, world units (the model is
            trained at 1); None: the world's ``route_cell`` (1 in a box world) for the route, and in a
            mesh world the body's long side over ``TRAINING_LONG_SIDE`` for the observation.
        centre: Reach in voxels of ``centre_route``: each interior route point moves to the clearest voxel
            centre that near (0: the search's route as it is).
        symmetry: Which of a class's four rotations a sample takes: ``"random"``; ``"ends"``, the one nearest
            the orientation of the query's end (start or goal) nearer the sample's route point; ``"chain"``, the one
            nearest a chain of rotations along the route (each route point's most probable class, its rotation the
            nearest to the point before's, from the start's orientation forward and from the goal's backward, each
            point taking the chain from the end nearer along the route); ``"chain_start"``, the chain from the start
            everywhere.
        min_confidence: A route sample whose nearest route point's largest class probability is below this, in
            [0, 1], takes uniform angles (0: the model's class wherever ``uniform_share`` does not say uniform).
        min_route_confidence: Where the largest class probability over all the route's points is below this, in
            [0, 1], every route sample of the query takes uniform angles (the ablation's draw).
        passage_weight: Route positions are drawn along the route with density ``1 + passage_weight * share``, share
            the solid share of the route point's observation patch (0 in the open; per segment the mean of its
            ends): 0 spreads them uniformly in arc length, a larger value crowds them where the route is tight.
        uniform_ramp: Samples over which the route samples' share of uniform angles rises to 1 (a tree's, 0: it
            stays ``uniform_share``): the ``k``-th sample the sampler draws for its query (counted from the route's
            first, after ``uniform_first``) takes uniform angles with
            probability ``uniform_share + (1 - uniform_share) * min(1, k / uniform_ramp)``, so a query the model's
            classes do not solve soon comes to the ablation's angles; on a mesh world a tree's share of uniform
            states comes over the same ramp (``TREES_KEEP``). A roadmap planner keeps every sample it draws and
            ignores it (``for_planner``).
        uniform_first: Samples a tree draws before the route (a tree's; 0: none): the first ``uniform_first`` samples
            of a query are uniform states (the goal with probability ``goal_share``), and the route, its centring and
            the model's pass are computed at the first sample after them, so a query that uniform sampling solves
            that soon never pays for them, and one it does not goes on from the trees grown so far. A roadmap planner
            ignores it (``for_planner``).
        stall_window: With a ``uniform_ramp``, the ramp's ``k`` counts only the samples drawn while the trees are
            stalled (0: every sample): while the gap along the route between the trees (the goal tree's least arc
            position reached, or the route's end for a single tree, less the start tree's greatest; a vertex's arc
            position is its nearest route point's) has not shrunk by a route voxel over the last ``stall_window``
            samples. A query whose trees keep moving along the route keeps the model's classes; one whose trees
            stand at a passage the classes do not pass turns to uniform angles. The draws then follow the trees
            (the planner's ``TreeView`` at each refill), so a seeded run is the same run, but a batch drawn whole is
            not the same as the same rows drawn in parts. A roadmap planner ignores it.
        follow: Half-width, in body radii (the world's ``radius``), of the window of arc length the route samples are
            drawn in (a tree's; 0: the whole route): about the start tree's greatest arc position reached, and with
            RRT-Connect half of them about the goal tree's least, so the samples lead each tree along the route
            rather than spreading over all of it. A new vertex's arc position is its nearest route point's among those
            within its tree's window, and counts only where that point lies within the half-width of it, so a
            tree's reach cannot jump through a wall to a far part of the route. A draw
            then returns at most ``FOLLOW_BATCH`` samples and follows the trees (``stall_window``'s caveat on
            batches holds); it is compiled (``planners.guidance.route_draws``: 0.03 to 0.05 ms for 64 samples, where
            numpy's draw takes 0.2 to 0.3; ``scripts/benchmark_rigid_route.py``). A roadmap planner ignores it.
        follow_share: With ``follow``, the probability in [0, 1] that a route sample is drawn in the trees' windows;
            the others are drawn along the whole route, as without ``follow``.
        roadmap: Settings a roadmap (PRM, Lazy-PRM, OB-PRM) takes instead of the ones above (``for_planner``), and
            every planner on a mesh world (at ``bind``), but a tree's ``route_fraction`` (``TREES_KEEP``: a tree
            keeps its uniform floor; with a ``uniform_ramp`` and no ``follow`` it starts at the roadmap's share of
            route samples and comes to its own over the ramp): any of ``ROADMAP_SETTINGS`` (``make_sampler`` gives
            the validated ``SHIPPED_RIGID_ROADMAP``).
    """

    def __init__(self, net, route_fraction: float = 0.75, uniform_share: float = 0.1, angle_noise: float = 0.1,
                 goal_share: float = 0.05, temperature: float = 1.0, spread: float | None = None,
                 cell: float | None = None, centre: int = 2, symmetry: str = "random",
                 min_confidence: float = 0.0, min_route_confidence: float = 0.0,
                 roadmap: dict | None = None, passage_weight: float = 0.0, uniform_ramp: float = 0.0,
                 uniform_first: float = 0.0, stall_window: float = 0.0, follow: float = 0.0,
                 follow_share: float = 1.0) -> None:
        who = "RigidRouteSampler"
        if symmetry not in SYMMETRY_RULES:
            raise InputError(f"{who}: symmetry = {symmetry!r}; choose from {', '.join(SYMMETRY_RULES)}")
        self.symmetry = symmetry
        self.centre = check_int(centre, f"{who}: centre", low=0)
        self.net = net
        self.route_fraction = float(check_number(who, "route_fraction", route_fraction, low=0, high=1))
        self.uniform_share = float(check_number(who, "uniform_share", uniform_share, low=0, high=1))
        self.angle_noise = float(check_number(who, "angle_noise", angle_noise, low=0))
        self.passage_weight = float(check_number(who, "passage_weight", passage_weight, low=0))
        self.uniform_ramp = float(check_number(who, "uniform_ramp", uniform_ramp, low=0))
        self.uniform_first = float(check_number(who, "uniform_first", uniform_first, low=0))
        self.stall_window = float(check_number(who, "stall_window", stall_window, low=0))
        self.follow = float(check_number(who, "follow", follow, low=0))
        self.follow_share = float(check_number(who, "follow_share", follow_share, low=0, high=1))
        self.goal_share = float(check_number(who, "goal_share", goal_share, low=0, high=1))
        self.temperature = float(check_number(who, "temperature", temperature, low=0, low_open=True))
        self.min_confidence = float(check_number(who, "min_confidence", min_confidence, low=0, high=1))
        self.min_route_confidence = float(check_number(who, "min_route_confidence", min_route_confidence, low=0,
                                                       high=1))
        self.spread = None if spread is None else float(check_number(who, "spread", spread, low=0))
        self.cell = None if cell is None else float(check_number(who, "cell", cell, low=0, low_open=True))
        if net is None and self.uniform_share < 1.0:
            raise InputError(f"{who}: without an orientation model every route sample takes uniform angles: "
                             f"uniform_share must be 1, got {self.uniform_share:g}")
        self.roadmap = dict(roadmap or {})
        unknown = sorted(set(self.roadmap) - set(ROADMAP_SETTINGS))
        if unknown:
            raise InputError(f"{who}: roadmap = {self.roadmap!r}: no setting {', '.join(unknown)}; a roadmap takes "
                             f"its own {', '.join(ROADMAP_SETTINGS)}")
        if self.roadmap.get("symmetry", symmetry) not in SYMMETRY_RULES:
            raise InputError(f"{who}: roadmap symmetry = {self.roadmap['symmetry']!r}; choose from "
                             f"{', '.join(SYMMETRY_RULES)}")
        for key, high in (("route_fraction", 1), ("uniform_share", 1), ("angle_noise", None), ("passage_weight", None),
                          ("uniform_ramp", None), ("uniform_first", None), ("stall_window", None), ("follow", None),
                          ("follow_share", 1)):
            if key in self.roadmap:
                self.roadmap[key] = float(check_number(who, f"roadmap {key}", self.roadmap[key], low=0, high=high))
        if net is None and self.roadmap.get("uniform_share", 1.0) < 1.0:
            raise InputError(f"{who}: without an orientation model a roadmap's route samples take uniform angles too: "
                             f"roadmap uniform_share must be 1, got {self.roadmap['uniform_share']:g}")

    def for_planner(self, family: str) -> SamplerBase:
        """This sampler with its ``roadmap`` settings for a roadmap planner (``"roadmap"``); else this sampler.

        A roadmap keeps every sample and joins each to its few nearest, so it needs samples in a passage's
        orientation all along the route at once, each at its neighbours' rotation: on the validation scenes PRM with
        ``SHIPPED_RIGID_ROADMAP`` connects 116 of 120 queries, with the trees' settings 84 (``docs/rigid-scenes.md``).
        """
        if family != FAMILY_ROADMAP or not (self.roadmap or self.uniform_ramp or self.uniform_first or self.follow):
            return self
        out = copy.copy(self)
        out._take_roadmap()
        out.uniform_ramp = 0.0  # a roadmap keeps every sample: no query is ever stuck on the ones it drew
        out.uniform_first = out.stall_window = out.follow = 0.0
        return out

    def _take_roadmap(self, keep: tuple[str, ...] = ()) -> None:
        """Take the ``roadmap`` settings in place of the trees', but ``keep`` (once: they are then this sampler's)."""
        for key, value in self.roadmap.items():
            if key not in keep:
                setattr(self, key, value)
        self.roadmap = {}

    def _setup(self) -> None:
        world = route_world(self.problem.world, "RigidRouteSampler")
        self._drawn = 0  # samples drawn for this query (``uniform_ramp``, ``uniform_first``)
        self._route_from = None  # the share of route samples a tree's ramp starts from (None: no ramp of it)
        if not hasattr(world, "boxes"):  # a mesh world: the trees take the roadmaps' settings too, but their floor
            start = self.roadmap.get("route_fraction")
            self._take_roadmap(TREES_KEEP)
            if start is not None and start != self.route_fraction and self.uniform_ramp > 0 and self.follow == 0:
                self._route_from = float(start)
        self._first = int(np.ceil(self.uniform_first))  # the uniform states before the route
        self.route = None
        if self._first == 0:
            self._route_setup(world)

    @property
    def routed(self) -> bool:
        """Whether this query's route has been computed (at ``bind``, or after ``uniform_first`` samples)."""
        return self.route is not None

    def _route_setup(self, world) -> None:
        """The query's route, its centring, the model's classes along it (once per query)."""
        from learning.models.rigid_orientation import class_probabilities
        from learning.models.threads import planning_threads

        cell = float(world.route_cell if self.cell is None else self.cell)
        self.rotations, seen = class_frame(world, self.cell)
        route = voxel_route(world, self.problem.start, self.problem.goal, cell)
        self.route = np.zeros((0, 3)) if route is None else centre_route(world, route, self.centre, cell)
        seg = np.linalg.norm(np.diff(self.route, axis=0), axis=1) if len(self.route) > 1 else np.zeros(0)
        self.arc = np.concatenate([[0.0], np.cumsum(seg)])
        self.sd = world.route_spread if self.spread is None else self.spread
        patches = None
        if len(self.route) and (self.net is not None or self.passage_weight > 0):
            seeds = np.stack([self.problem.start[:3], self.problem.goal[:3]])
            half = PATCH_HALF if self.net is None else self.net.half
            patches, dirs = route_observation(world, self.route, seen, half, seeds=seeds)
        if patches is not None and self.net is not None:
            with planning_threads():  # one torch thread unless SAMPLERGYM_TORCH_THREADS says otherwise
                self.probs = class_probabilities(self.net, patches, dirs, self.temperature)
        else:
            self.probs = np.full((0, N_CLASSES), 1.0 / N_CLASSES)
        self.cdf = np.cumsum(self.probs, axis=1)
        # the route's length as the draws see it: each segment weighted by how tight the route is there
        self.warc = self.arc
        if self.passage_weight > 0 and len(self.route) > 1:
            share = patches.reshape(len(patches), -1).mean(axis=1, dtype=np.float64)
            self.warc = np.concatenate([[0.0], np.cumsum(np.diff(self.arc) * (
                1.0 + self.passage_weight * 0.5 * (share[:-1] + share[1:])))])
        # the route points whose class the samples take (without a model no sample takes one: uniform_share is 1)
        self.sure = (self.probs.max(axis=1) >= self.min_confidence if len(self.probs) == len(self.route)
                     else np.ones(len(self.route), dtype=bool))
        if len(self.probs) and self.probs.max() < self.min_route_confidence:
            self.sure[:] = False  # the model sees no passage that needs a turn: the ablation's uniform angles
        self.ends = rotation_matrices(np.stack([self.problem.start[3:6], self.problem.goal[3:6]]))
        # the rotation each route point's samples come nearest among their class's four (not with "random"): the
        # orientation of the query's end nearer the point, or the chain's at the point
        self.refs = np.zeros((len(self.route), 3, 3))
        if self.symmetry == "ends":
            self.refs = self.ends[nearer_end(self.route, self.problem.start, self.problem.goal)]
        elif self.symmetry in ("chain", "chain_start") and len(self.probs) == len(self.route) and len(self.route):
            self.refs = rotation_chain(self.rotations, self.probs.argmax(axis=1), self.ends, self.arc,
                                       start_only=self.symmetry == "chain_start")
        self._top = np.nextafter(self.high[:3], -np.inf)  # a position's upper clip: inside the bounds
        # the stall clock (``stall_window``), from the route's first sample: the arc positions the start and goal
        # trees have reached, their vertices seen, the gap's last shrinking, the samples drawn while stalled
        # and the windows the route samples follow (``follow``): half-width in arc length, and whether a goal tree grows
        self._reach, self._seen, self._gap, self._moved = [0.0, float(self.arc[-1])], [0, 0], np.inf, self._drawn
        self._clock, self._stalled = 0, False
        self._span, self._two = self.follow * float(world.radius), False

    def draw(self, rng, n, view):
        # one row of uniforms per sample keeps the stream identical whatever the batch size: a coin, an
        # arc length, a uniform state, two Box-Muller pairs for the position, a coin for uniform angles,
        # a class, a symmetry, two Box-Muller pairs for the rotation noise
        d = self.problem.dim
        if self.follow > 0:
            n = min(n, FOLLOW_BATCH)
        u = rng.random((n, 13 + d))
        if self.route is not None and (self.follow > 0 or (self.uniform_ramp > 0 and self.stall_window > 0)):
            self._watch(view)
        first = max(0, min(n, self._first - self._drawn))
        if first:  # the uniform states before the route (``uniform_first``)
            pts = self._uniform(u[:first, 2:2 + d])
            pts[u[:first, 0] < self.goal_share] = self.problem.goal
            self._drawn += first
            if first == n:
                return pts
            return np.concatenate([pts, self._draw_routed(u[first:])])
        return self._draw_routed(u)

    def _watch(self, view) -> None:
        """Update the trees' reach along the route (``stall_window``, ``follow``) from the planner's ``view``."""
        if view is not None and len(self.route) > 1:
            two = watch_reach(view, self.route, self.arc, self._reach, self._seen, self._span, self.follow > 0)
            self._two = self._two or two
            gap = self._reach[1] - self._reach[0]
            if gap < self._gap - float(self.problem.world.route_cell):
                self._gap, self._moved = gap, self._drawn
        self._stalled = self.stall_window > 0 and self._drawn - self._moved >= self.stall_window

    def _draw_routed(self, u: np.ndarray) -> np.ndarray:
        """The samples of the rows ``u`` (one row of uniforms per sample), the route's from the first on."""
        if self.route is None:
            self._route_setup(route_world(self.problem.world, "RigidRouteSampler"))
        if self.follow > 0:
            return self._draw_following(u)
        n, d = len(u), self.problem.dim
        pos_z = box_muller(u[:, 2 + d:6 + d])[:, :3]
        cls_u, sym_u, rot_z = u[:, 7 + d], u[:, 8 + d], box_muller(u[:, 9 + d:13 + d])[:, :3]
        pts = self._uniform(u[:, 2:2 + d])
        if self.arc[-1] > 0:
            if self.uniform_ramp > 0:  # each sample's place on the ramp
                if self.stall_window > 0:  # the stall clock: it runs only while the trees stand still
                    k = self._clock + (np.arange(n) if self._stalled else np.zeros(n))
                else:
                    k = self._drawn - self._first + np.arange(n)  # counted from the route's first sample
                ramp = np.minimum(1.0, k / self.uniform_ramp)
            fraction = self.route_fraction
            if self._route_from is not None:  # a tree's floor comes over the ramp
                fraction = self._route_from + (self.route_fraction - self._route_from) * ramp
            on = (u[:, 0] >= self.goal_share) & (u[:, 0] < self.goal_share + (1.0 - self.goal_share) * fraction)
            s = u[on, 1] * self.warc[-1]
            i = np.clip(np.searchsorted(self.warc, s, side="right") - 1, 0, len(self.route) - 2)
            t = (s - self.warc[i]) / np.maximum(self.warc[i + 1] - self.warc[i], 1e-300)
            p = self.route[i] + t[:, None] * (self.route[i + 1] - self.route[i]) + self.sd * pos_z[on]
            pts[on, :3] = np.clip(p, self.low[:3], self._top)
            near = i + (t >= 0.5)
            share = self.uniform_share
            if self.uniform_ramp > 0:
                share = share + (1.0 - share) * ramp[on]
            take = (u[on, 6 + d] >= share) & self.sure[near]
            learned, near = np.flatnonzero(on)[take], near[take]
            if len(learned):
                cls = np.minimum((self.cdf[near] < cls_u[learned, None]).sum(axis=1), N_CLASSES - 1)
                sym = np.minimum((sym_u[learned] * 4).astype(np.int64), 3)
                if self.symmetry != "random":  # the rotation nearest a reference's (largest trace): the nearer
                    # end's orientation, or the chain's at the route point
                    sym = np.einsum("nsij,nij->ns", self.rotations[cls], self.refs[near]).argmax(axis=1)
                base = self.rotations[cls, sym]
                turn = small_rotations(self.angle_noise * rot_z[learned])
                pts[learned, 3:] = euler_from_matrices(turn @ base)
        pts[u[:, 0] < self.goal_share] = self.problem.goal
        self._drawn += n
        if self._stalled:
            self._clock += n
        return pts

    def _draw_following(self, u: np.ndarray) -> np.ndarray:
        """``_draw_routed`` with ``follow``, compiled (``planners.guidance.route_draws.follow_draw``): the route
        samples drawn within the trees' windows, ``follow_share`` of them (with a goal tree, half about each tree's
        reach), the rest along the whole route.
        """
        n, d = len(u), self.problem.dim
        total = float(self.arc[-1])
        reach = np.array([self._reach[0], self._reach[1]])
        ends = np.clip(np.stack([reach - self._span, reach + self._span], axis=1), 0.0, total)
        windows = np.interp(ends, self.arc, self.warc)  # (tree, low/high) in weighted arc length
        k0, k_step = 0, False
        if self.uniform_ramp > 0:
            if self.stall_window > 0:  # the stall clock: it runs only while the trees stand still
                k0, k_step = self._clock, self._stalled
            else:
                k0, k_step = self._drawn - self._first, True  # counted from the route's first sample
        pts = np.empty((n, d))
        follow_draw(u, pts, self.low, self.high, self._top, np.asarray(self.problem.goal, dtype=np.float64),
                    float(self.goal_share), float(self.route_fraction), self.route, self.warc, windows, self._two,
                    float(self.follow_share), float(self.sd), float(self.uniform_share), float(self.uniform_ramp),
                    float(k0), bool(k_step), self.sure, self.cdf, self.rotations, self.refs,
                    self.symmetry != "random", float(self.angle_noise))
        self._drawn += n
        if self._stalled:
            self._clock += n
        return pts

    def __repr__(self) -> str:
        sd = "the world's" if self.spread is None else f"{self.spread:g}"
        cell = "the world's" if self.cell is None else f"{self.cell:g}"
        return (f"RigidRouteSampler(route_fraction={self.route_fraction:g}, uniform_share={self.uniform_share:g}, "
                f"angle_noise={self.angle_noise:g}, goal_share={self.goal_share:g}, "
                f"temperature={self.temperature:g}, spread={sd}, cell={cell}, centre={self.centre}, "
                f"symmetry={self.symmetry!r}, min_confidence={self.min_confidence:g}, "
                f"min_route_confidence={self.min_route_confidence:g}"
                + (f", uniform_ramp={self.uniform_ramp:g}" if self.uniform_ramp else "")
                + (f", uniform_first={self.uniform_first:g}" if self.uniform_first else "")
                + (f", stall_window={self.stall_window:g}" if self.stall_window else "")
                + (f", follow={self.follow:g}" if self.follow else "")
                + (f", follow_share={self.follow_share:g}" if self.follow and self.follow_share < 1 else "")
                + (f", roadmap={self.roadmap!r})" if self.roadmap else ")"))
