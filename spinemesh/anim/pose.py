"""Sampling an animation: the skeleton's pose and every drawn attachment at a time.

A game plays an animation with an ``AnimationState``: each frame it advances the track time,
applies every timeline of the animation at ``track time % duration`` (looping), then calls
``updateWorldTransform``. On track 0 with nothing to mix from, every timeline *replaces* what
it drives (``MixBlend.first`` at alpha 1): before its first key the setup value, else the
keyed value (rotate, translate and shear added to the setup value, scale multiplied by it).
What no timeline drives keeps its setup value. This module does the same, from the setup
pose each time (so a pose does not depend on the poses sampled before it), then poses the
bones with the runtime's update cache (:mod:`spinemesh.rig.constraints`) and places every
drawn attachment (:mod:`.attachments`).

Physics constraints (4.2, 4.3) keep state from frame to frame: a pose of a skeleton with
physics replays the game loop from time 0 in the harness's steps (:mod:`spinemesh.rig.physics`),
as the runtime plays it, reset keys included (4.3 drawing its bones between physics steps).
Not reproduced: 3.8 local transform constraints that write shear into the bone's own local
shear, which then carries over from frame to
frame in the runtime, are applied as in the setup pose.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SpineMeshError
from ..limits import MAX_PHYSICS_FPS, MAX_POSE_STEPS
from ..rig.constraints.families import constraints_of, is_43, path_slot, posing_family
from ..rig.constraints.solver import Rig, build_rig, skin_names, update_world
from ..rig.physics import RESET, UPDATE, PhysicsSettings, PhysicsState
from ..rig.transform import wrap_turns
from ..rig.transform43 import PROPERTIES, source_value_43
from ..skeleton import first_of_each_name, skins_by_name, spine_version
from ..skeleton_curves import curve_spelling
from ..skeleton_version import major_minor
from .attachments import Prepared, RegionGeometry, prepare
from .curves import _number, search
from .timelines import Animation, color_channels, made_when_needed, read_animation

#: What reading or playing an animation raises where a document the loader let through holds
#: what the sampler cannot play (a field of the wrong type, a key or index that is not there, a
#: zero span): the animation is then left out by whoever samples it, never the whole skeleton.
POSE_ERRORS = (SpineMeshError, KeyError, ValueError, TypeError, IndexError, ZeroDivisionError)

#: The runtimes' blend mode names, as the harness's dump writes them.
BLEND_MODES = ("normal", "additive", "multiply", "screen")


@dataclass
class DrawnSlot:
    """One drawn attachment of a pose.

    Attributes
    ----------
    slot, bone : str
        The slot and its bone.
    attachment : str
        The runtime's attachment name (its ``name`` field, else its key in the skin).
    key, skin : str
        Its key in the skin and the skin it was found in (the skeleton's skin, else ``default``).
    path : str
        The image it draws (a sequence: the frame shown).
    type : str
        ``"region"`` or ``"mesh"`` (linked meshes are meshes).
    blend : str
        The slot's blend mode.
    color : ndarray, shape (4,)
        RGBA 0..1: skeleton colour times slot colour times attachment colour.
    vertices : ndarray, shape (N, 2)
        World positions (Spine world units, y up); a region's corners are bottom-left,
        top-left, top-right, bottom-right.
    uvs : ndarray, shape (N, 2)
        The same vertices in the attachment's original image (u right, v down, 0..1): map
        them through the atlas region (offsets, rotation) to sample the page.
    triangles : ndarray, shape (3T,)
        Vertex indices.
    hull : int or None
        Mesh: the number of hull vertices (``hull`` field).
    clip : ndarray, shape (M, 2), or None
        The world polygon of the clipping attachment that clips this slot, if any.
    exact : bool
        False when a bone it follows is not reproduced exactly (see :attr:`Pose.exact`).
    dark : ndarray, shape (3,), or None
        The slot's dark colour (two-colour tint, RGB, 0..1 as keyed: 4.0 to 4.2 do not clamp
        it, 3.8 and 4.3 do), None for a slot without one, which the runtimes draw with the light colour alone.
        Neither the skeleton's nor the attachment's colour multiplies it.
    """

    slot: str
    bone: str
    attachment: str
    key: str
    skin: str
    path: str
    type: str
    blend: str
    color: np.ndarray
    vertices: np.ndarray
    uvs: np.ndarray
    triangles: np.ndarray
    hull: int | None = None
    clip: np.ndarray | None = None
    exact: bool = True
    dark: np.ndarray | None = None


@dataclass
class Pose:
    """A sampled pose.

    Attributes
    ----------
    time : float
        The track time asked for (seconds); ``animation_time`` the time within the animation.
    bones : list of str
        Bone names in skeleton order.
    world : ndarray, shape (B, 2, 3)
        Each bone's world transform ``[[a, b, worldX], [c, d, worldY]]``.
    slots : list of DrawnSlot
        Drawn region and mesh attachments in draw order.
    exact : ndarray, shape (B,), bool
        False for bones whose transform is not the runtime's (``why`` says why by name).
    active : ndarray, shape (B,), bool
        False for bones the skin does not use (the runtime does not pose them; here they
        follow their parent).
    """

    time: float
    animation_time: float
    bones: list[str]
    world: np.ndarray
    slots: list[DrawnSlot]
    exact: np.ndarray
    active: np.ndarray
    why: dict[str, str] = field(default_factory=dict)

    def bone(self, name: str) -> np.ndarray:
        """The world transform (2, 3) of the bone called ``name`` (KeyError if none)."""
        try:
            return self.world[self.bones.index(name)]
        except ValueError:
            raise KeyError(name) from None

    def to_dump(self, digits: int = 6) -> dict:
        """This pose in the layout of the official-runtime harness's dump (one entry of
        ``poses``, without label): ``bones`` name -> ``[a, b, c, d, worldX, worldY]``, and
        ``attachments``, one dict per drawn slot (``slot``, ``bone``, ``attachment``, ``path``,
        ``type``, ``blend``, ``color``, ``dark`` (only for a slot with a dark colour), ``vertices`` flat, ``uvs`` flat (original image),
        ``triangles``, ``hull``, ``clip``, and ``exact``). Numbers rounded to ``digits`` decimals;
        one that is not finite (a degenerate pose) becomes None."""
        def r(values) -> list[float]:
            return [_clean(round(float(v), digits)) for v in np.asarray(values, float).reshape(-1)]
        bones = {name: r(m[[0, 0, 1, 1, 0, 1], [0, 1, 0, 1, 2, 2]]) for name, m in zip(self.bones, self.world)}
        # The runtime's (a, b, c, d) are M[0,0], M[0,1], M[1,0], M[1,1].
        attachments = [{
            "slot": s.slot, "bone": s.bone, "attachment": s.attachment, "path": s.path, "type": s.type,
            "blend": s.blend, "color": r(s.color), **({} if s.dark is None else {"dark": r(s.dark)}),
            "vertices": r(s.vertices), "uvs": r(s.uvs), "triangles": [int(i) for i in s.triangles], "hull": s.hull,
            "clip": None if s.clip is None else r(s.clip), "exact": s.exact} for s in self.slots]
        return {"bones": bones, "attachments": attachments}


@dataclass
class _Frame:
    """The animated values of one frame, before the bones are posed."""

    time: float
    local: list                      # per bone: x, y, rotation, scaleX, scaleY, shearX, shearY (the setup tuple until a timeline sets one)
    inherit: list[str]
    data: dict                       # constraint id -> its current JSON values
    names: list                      # per slot: attachment key or None
    colors: list
    darks: list                      # per slot: its dark colour (RGB) or None
    order: list[int]
    sequence: list[int]
    shown: list = field(default_factory=list)
    deform: dict = field(default_factory=dict)


def _clean(v: float) -> float | None:
    if not math.isfinite(v):
        return None  # a degenerate pose: strict JSON has no NaN
    return 0.0 if v == 0 else v  # no "-0.0"


def steps_of(time: float, fps: float) -> tuple[int, float]:
    """The harness's game-loop steps to reach ``time``: their count, ``round(time * fps)``, and
    their length (0 and 0.0 for a time of 0)."""
    if not math.isfinite(time) or time <= 0 or fps <= 0:
        return 0, 0.0
    steps = math.floor(time * fps + 0.5)
    return steps, (time / steps if steps else 0.0)


def summed(start: float, step: float, count: int) -> float:
    """``start`` with ``step`` added ``count`` times, one addition after another as a game loop
    adds its frames: the same rounding (``np.add.accumulate`` adds in order), at C speed.

    Beyond :data:`~spinemesh.limits.MAX_POSE_STEPS` additions (hours of game loop, which no
    pose asked for by ``spinemesh pose`` reaches), ``start + step * count``: time and memory stay
    bounded whatever a file's times say.
    """
    if count <= 0:
        return start
    if count > MAX_POSE_STEPS:
        return start + step * count
    values = np.full(count + 1, step)
    values[0] = start
    return float(np.add.accumulate(values)[-1])


def animation_time(time: float, duration: float, fps: float = 60.0, loop: bool = True) -> float:
    """The time within the animation that a game reaches at track time ``time``.

    The harness (and a game loop at ``fps``) advances the track in ``round(time * fps)``
    equal steps, adding each step to the track time; a looping track then applies the
    animation at ``track time % duration`` (the remainder carries the steps' rounding,
    which decides which side of a loop boundary a time on it falls). Beyond
    :data:`~spinemesh.limits.MAX_POSE_STEPS` steps (an animation hours long) the track time is
    their product, so that a key at ``1e30`` s costs no more than one at 1 s.
    """
    steps, dt = steps_of(time, fps)
    return _track_to_animation(summed(0.0, dt, steps), duration, loop)


def _track_to_animation(track: float, duration: float, loop: bool) -> float:
    """The animation time a track at ``track`` s applies: looping, ``track % duration`` (0.0 for
    an animation of no duration); else ``track`` itself."""
    if not loop:
        return track
    return math.fmod(track, duration) if duration > 0 else 0.0


class DeformKeys:
    """A deform timeline's vertices at each key, in the runtimes' layout (float32; the setup
    vertices added for an unweighted mesh), made when a key is first needed.

    Not all at once: a timeline of 100,000 empty keys (``{}``, three bytes each) on a mesh of
    10,000 numbers would otherwise ask for 8 GB (:func:`~.timelines.made_when_needed`).

    Parameters
    ----------
    raw : list of (int, list or None)
        Per key, its ``offset`` and ``vertices`` as stored.
    setup : ndarray, shape (N,)
        The attachment's vertices as its deform keys count them.
    weighted : bool
        Whether the offsets are added to the setup vertices (unweighted) or are the values.
    """

    def __init__(self, raw: list, setup: np.ndarray, weighted: bool):
        self.raw, self.setup, self.weighted = raw, setup, weighted
        self._made: dict[int, np.ndarray] = {}

    def __len__(self) -> int:
        return len(self.raw)

    def __getitem__(self, i: int) -> np.ndarray:
        return made_when_needed(self._made, i, self._make)

    def _make(self, i: int) -> np.ndarray:
        offset, verts = self.raw[i]
        values = np.zeros(len(self.setup))
        if isinstance(verts, list) and 0 <= offset < len(self.setup):
            v = np.asarray([_number(x, 0.0) for x in verts[:len(self.setup) - offset]], float)
            values[offset:offset + len(v)] = v
        if not self.weighted:
            values += self.setup
        return values.astype(np.float32).astype(np.float64)


class Sampler:
    """A skeleton document prepared once for sampling: bones, update cache, slots, attachments.

    Parameters
    ----------
    doc : dict
        A skeleton document (:func:`spinemesh.skeleton.load_skeleton`; ``.json`` or ``.skel``).
    skin : str or tuple of str, optional
        The skin to show (default: none, the default skin only), as ``Skeleton.setSkin``; a
        tuple: those skins combined, as a game dresses a mix-and-match character (each
        attachment looked up in them in order, then in the default skin; their bones and
        constraints all active; :func:`spinemesh.rig.constraints.solver.skin_names`).
    regions : callable, optional
        ``regions(path) -> RegionGeometry | None``: the atlas region a region attachment draws
        (its stored size and offsets decide the quad). See :func:`atlas_regions`. Without it
        every image is taken as stored whole.
    """

    def __init__(self, doc: dict, skin: str | None = None, regions=None):
        self.doc = doc
        version = spine_version(doc)
        known = major_minor(version)
        self.four = known is None or known[0] >= 4
        #: 4.3's colour timelines clamp every channel they set (:meth:`_apply_slots`)
        self.colours_clamped = is_43(doc)
        self.curve_spelling = curve_spelling(version)  # 3.x: how its keys' curves are spelled
        self.skin = skin
        #: the skins an attachment is looked up in before the default skin, first first
        self.looked_in = [n for n in skin_names(skin) if n != "default"]
        self.rig: Rig = build_rig(doc, skin, posing_family(doc))
        #: per bone, whether the skin uses it (set when the rig is built, the same in every pose)
        self.active = [b.active for b in self.rig.bones]
        self._active = np.array(self.active)
        self.rig.where = "in this pose"
        self.bone_names = [b.name for b in self.rig.bones]
        #: per bone, its setup values as a tuple of float: a frame's bones hold these very tuples
        #: until a timeline changes one (copied then, :meth:`_apply_bones`)
        self.setup_local = [tuple(map(float, b.local)) for b in self.rig.bones]
        self.setup_inherit = [b.inherit for b in self.rig.bones]
        self.setup_data = {id(c): c.data for c in self.rig.constraints}
        self.constraints = {(c.kind, c.name): c for c in self.rig.constraints}
        slots = [s for s in doc.get("slots", []) if isinstance(s, dict)]
        bone_index = {n: i for i, n in enumerate(self.bone_names)}
        self.slot_names = [str(s.get("name")) for s in slots]
        self.slot_bones = [bone_index.get(str(s.get("bone")), 0) for s in slots]
        self.slot_setup = [s.get("attachment") for s in slots]
        self.slot_color = [np.array(color_channels(s.get("color", "ffffffff"), 4)) for s in slots]
        #: per slot, its setup dark colour (two-colour tint) or None: the runtimes give a slot a
        #: dark colour only where its data has one
        self.slot_dark = [np.array(color_channels(s["dark"], 3)) if isinstance(s.get("dark"), str) and s["dark"]
                          else None for s in slots]
        self.slot_blend = [s.get("blend", "normal") if s.get("blend", "normal") in BLEND_MODES else "normal"
                           for s in slots]
        self.skins = skins_by_name(doc)
        self.slot_index = first_of_each_name(self.slot_names)
        #: slots whose attachment moves bones (a path constraint's target): a step between drawn
        #: frames applies these slots' timelines only
        self.path_slots = sorted({self.slot_index[t] for c in self.rig.constraints if c.kind == "path"
                                  for t in [path_slot(self.setup_data[id(c)])] if t in self.slot_index})
        self._regions = regions or (lambda path: None)
        self._prepared: dict[tuple[str, int, str], Prepared | None] = {}
        self._found: dict[tuple[int, str], Prepared | None] = {}   # attachment(slot, key)
        self._alike: dict[tuple[int, int], tuple] = {}   # another sampler's attachment places as one of ours
        self.physics_bones = self._physics_bones()
        self.physics: list[PhysicsState] = []
        four_three = is_43(doc) and posing_family(doc) is not None
        for c in self.rig.constraints:
            if c.kind == "physics" and c.active and self.rig.family == "4.2":
                settings = PhysicsSettings.from_json(c.data, doc.get("skeleton") or {}, four_three)
                if settings.step * MAX_PHYSICS_FPS < 1:  # a step per frame for each of millions: flagged
                    continue
                c.physics = PhysicsState(settings)
                self.physics.append(c.physics)
        #: Bones of active physics constraints that are not stepped even when physics is (too fine).
        self.unstepped_bones = {b: n for b, n in self.physics_bones.items()
                                if not any(c.physics is not None for c in self.rig.constraints
                                           if c.kind == "physics" and c.name == n)}
        self._animations: dict[str, tuple[Animation, dict]] = {}
        for c in self.rig.constraints:
            if c.kind == "slider":
                c.slider = SliderPlayer(self, c.data)

    # -- attachments ---------------------------------------------------------------------
    def prepared(self, skin: str, slot: int, key: str) -> Prepared | None:
        """The attachment ``key`` of ``slot`` in ``skin`` (that skin only), prepared once."""
        k = (skin, slot, key)
        if k not in self._prepared:
            # a skin's attachments are the first slot's of their slot name (findSlot): a later slot
            # of that name has none
            name = self.slot_names[slot]
            att = ((self.skins.get(skin) or {}).get(name) or {}).get(key) if self.slot_index[name] == slot else None
            self._prepared[k] = None if not isinstance(att, dict) else prepare(
                self.skins, skin, slot, self.slot_names[slot], key, att, len(self.bone_names), self._regions,
                self.slot_index)
        return self._prepared[k]

    def attachment(self, slot: int, key: str | None) -> Prepared | None:
        """``Skeleton.getAttachment``: the skeleton's skin first, then the default skin (found once)."""
        if key is None:
            return None
        k = (slot, key)
        if k not in self._found:
            found = None
            for skin in self.looked_in:
                found = self.prepared(skin, slot, key)
                if found is not None:
                    break
            self._found[k] = found if found is not None else self.prepared("default", slot, key)
        return self._found[k]

    # -- animations ----------------------------------------------------------------------
    def animation_names(self) -> list[str]:
        """The skeleton's animations, in document order."""
        return [str(n) for n in (self.doc.get("animations") or {})]

    def duration(self, animation: str) -> float:
        """The animation's duration in seconds, as the runtimes compute it (its last key)."""
        return self.animation(animation)[0].duration

    def animation(self, name: str) -> tuple[Animation, dict]:
        """The animation's timelines and its deforms in the runtimes' layout, read once."""
        if name not in self._animations:
            if name not in (self.doc.get("animations") or {}):
                raise KeyError(name)
            anim = read_animation(self.doc, name, self.four, self.curve_spelling)
            deforms = {}
            for d in anim.deforms:
                att = self.prepared(d.skin, d.slot, d.attachment)
                if att is None or att.geometry is None:
                    continue
                deforms[(d.skin, d.slot, d.attachment)] = (d.keys, DeformKeys(d.raw, att.geometry.setup,
                                                                               att.geometry.weighted))
            self._animations[name] = (anim, deforms)
        return self._animations[name]

    def _physics_bones(self) -> dict[int, str]:
        """Bones that active physics constraints move, with the constraint's name (every
        physics constraint of a version whose constraints are not solved)."""
        out: dict[int, str] = {}
        for c in self.rig.constraints:
            if c.kind == "physics" and c.active:
                for b in c.bones:
                    out.setdefault(b.index, c.name)
        return out

    # -- sampling ------------------------------------------------------------------------
    def pose(self, animation: str | None, time: float = 0.0, fps: float = 60.0, loop: bool = True,
             physics: bool = True, clock: float = 0.0) -> Pose:
        """The pose of ``animation`` at track time ``time`` (seconds); the setup pose when
        ``animation`` is None. See :func:`animation_time` for ``fps`` and ``loop``.

        With physics constraints (4.2, 4.3; and ``physics``), the game loop is replayed from time 0
        in steps of ``1 / fps`` s, as physics needs every frame before the pose: a pose then
        costs one bone update per step. Without ``physics`` the bones physics moves keep the
        animation's pose and are flagged not exact. ``clock`` is the skeleton's time when the
        replay starts: physics steps by differences of it, and their rounding (a step taken a
        frame later when the clock's sum falls just short of 1/60 s) depends on where it starts;
        a game starts at 0, the harness carries it from one pose to the next
        (:func:`spinemesh.anim.dump.dump` does too). For many times of one animation with
        physics (a player's frames), :meth:`play` costs one replay instead of one per time.
        """
        if animation is None:
            for state in self.physics:
                state.mode = RESET
            frame = self._frame(None, 0.0, -1.0)
            # physics reset moves no bone (4.2 and 4.3 alike): the setup pose is exact, stepped or not
            return self._finish(time, frame, *self._pose_bones(frame, flagged={}))
        if physics and self.physics:
            steps, dt = steps_of(time, fps)
            return self._finish(time, *next(self._replay(animation, [steps], dt, loop, clock)))
        return self._finish(time, *self._posed(animation, time, fps, loop))

    def play(self, animation: str, times, fps: float = 60.0, loop: bool = True, physics: bool = True):
        """Poses of ``animation`` at each of ``times`` (seconds, ascending) along one game loop.

        The loop advances in steps of exactly ``1 / fps`` s from 0, and a time is shown at the
        step nearest to it, as a game or a player shows it: with physics, every time costs only
        the steps since the one before (:meth:`pose` replays from 0 for each), so playing a
        whole animation at 30 frames per second costs one pass. Poses without physics are
        :meth:`pose`'s.

        Yields
        ------
        Pose
        """
        times = _ascending(times)
        if not (physics and self.physics):
            for t in times:
                yield self.pose(animation, t, fps, loop, physics)
            return
        targets = _nearest_steps(times, fps)
        for t, result in zip(times, self._replay(animation, targets, 1 / fps, loop, 0.0)):
            yield self._finish(t, *result)

    def play_pair(self, twin: Sampler, animation: str, times, fps: float = 60.0, loop: bool = True,
                  physics: bool = True):
        """:meth:`play` of this sampler and of ``twin`` together, the bones posed once for both.

        ``twin`` samples a skeleton whose bones move as this one's (:func:`same_motion`, the
        same skin): an upgraded skeleton beside its original, which differ in attachments only.
        Each step of the game loop (constraints, physics) is then computed once and its bone
        transforms drawn with each skeleton's own attachments, which halves the work of a
        preview's two sides. Where the twin's animation lasts otherwise (a deform key
        beyond the bones' last one), each is played on its own.

        Yields
        ------
        (Pose, Pose)
            This sampler's pose and ``twin``'s at each of ``times`` (seconds, ascending).
        """
        times = _ascending(times)
        if self.duration(animation) != twin.duration(animation):
            yield from zip(self.play(animation, times, fps, loop, physics),
                           twin.play(animation, times, fps, loop, physics))
            return
        if physics and self.physics:
            targets = _nearest_steps(times, fps)
            posed = self._replay(animation, targets, 1 / fps, loop, 0.0)
        else:
            posed = (self._posed(animation, t, fps, loop) for t in times)
        for t, (frame, world, exact, why) in zip(times, posed):
            placed: dict = {}
            mine = self._finish(t, frame, world, exact, why, placed=placed)
            theirs = twin._frame(animation, frame.time, -1.0, bones=False)
            yield mine, twin._finish(t, theirs, world, exact.copy(), dict(why), like=placed)

    def _posed(self, animation: str, time: float, fps: float, loop: bool):
        """``(frame, world, exact, why)`` of :meth:`pose` at ``time`` where no physics is
        stepped (the bones of physics constraints flagged when there are some)."""
        anim = self.animation(animation)[0]
        for state in self.physics:
            state.mode = RESET
        frame = self._frame(animation, animation_time(time, anim.duration, fps, loop), -1.0,
                            carried=_carried_rotations(anim, self.setup_local, self.active, time, fps, loop))
        return (frame, *self._pose_bones(frame, flagged=self.physics_bones))

    def bone_worlds(self, animation: str, time: float, fps: float = 60.0, loop: bool = True) -> np.ndarray:
        """The bones' world transforms (B, 2, 3) of ``animation`` at track time ``time``, without
        physics (its bones keep the animation's pose) and without drawing any attachment: the
        cheap part of :meth:`pose`, for callers that only need where the bones go."""
        return self._posed(animation, time, fps, loop)[1]

    def _finish(self, time: float, frame: _Frame, world: np.ndarray, exact: np.ndarray, why: dict,
                placed: dict | None = None, like: dict | None = None) -> Pose:
        """The pose of a frame whose bones are posed: its drawn attachments (``placed`` and
        ``like``: see :meth:`_draw`)."""
        active = self.active
        slots = self._draw(world, frame, active, placed, like)
        if not exact.all():
            for drawn, s in zip(slots, (self.slot_names.index(d.slot) for d in slots)):
                att = frame.shown[s]
                used = att.geometry.bone if att.geometry is not None and att.geometry.weighted else [self.slot_bones[s]]
                drawn.exact = bool(exact[used].all())
        return Pose(float(time), frame.time, list(self.bone_names), world, slots, exact, self._active.copy(), why)

    def _replay(self, animation: str, targets: list[int], dt: float, loop: bool, clock: float):
        """The harness's game loop: the setup pose with physics reset, the animation applied
        at track time 0, then steps of ``dt`` s, physics updated at each; yields
        ``(frame, world, exact, why)`` at each step count of ``targets`` (ascending)."""
        anim = self.animation(animation)[0]
        if targets and targets[-1] > MAX_POSE_STEPS:  # each step is replayed: refused, not hours of work
            raise SpineMeshError(f"animation {animation!r}: {targets[-1] * dt:g} s is over {MAX_POSE_STEPS:,} "
                                 "game-loop steps of its physics")
        for state in self.physics:
            state.clock, state.mode = clock, RESET
        self._pose_bones(self._frame(None, 0.0, -1.0), flagged={})
        for state in self.physics:
            state.mode = UPDATE
        track, last = 0.0, -1.0
        pending = list(targets)
        for i in range((pending[-1] if pending else 0) + 1):
            if i:
                track += dt
                clock += dt
                for state in self.physics:
                    state.clock = clock
            t = _track_to_animation(track, anim.duration, loop)
            if pending and pending[0] == i:
                frame = self._frame(animation, t, last)
                result = self._pose_bones(frame, flagged=self.unstepped_bones)
            else:  # a step no pose is drawn at: its bones only, for the physics that carries over
                self._step_bones(self._frame(animation, t, last, drawn=False))
            last = t
            while pending and pending[0] == i:
                pending.pop(0)
                yield (frame, *result)

    def _frame(self, animation: str | None, t: float, last: float, bones: bool = True,
               drawn: bool = True, carried: dict[int, float] | None = None) -> _Frame:
        """Every timeline of ``animation`` applied at animation time ``t`` over the setup
        values (``last``: the time applied the frame before, for physics resets). Not
        ``bones``: another sampler poses the bones (:meth:`play_pair`'s twin), so bone and
        constraint timelines and physics resets are left out (the frame's bone and constraint
        values stay the setup's). Not ``drawn``: only what poses the bones (a step between
        drawn frames), the slots that no path constraint follows left without colour, order
        and attachment. ``carried``: the angles of 3.7 and 3.8 rotate timelines replayed frame by frame
        (:func:`_carried_rotations`), by the timeline's place in the animation's bone timelines."""
        if not drawn and animation is not None:
            return self._bones_frame(animation, t, last)
        n_slots = len(self.slot_names)
        # the setup values themselves, each copied where a timeline changes it (most stay)
        frame = _Frame(t, list(self.setup_local), list(self.setup_inherit), dict(self.setup_data),
                       list(self.slot_setup), list(self.slot_color), list(self.slot_dark), list(range(n_slots)),
                       [-1] * n_slots)
        deforms: dict = {}
        active = self.active
        if animation is not None:
            anim, deforms = self.animation(animation)
            if bones:
                self._apply_bones(anim, t, frame.local, frame.inherit, active, carried)
                self._apply_constraints(anim, t, frame.data)
            self._apply_slots(anim, t, frame.names, frame.colors, active, frame.darks)
            if bones:
                self._physics_resets(anim, last, t)
            if anim.draw_order is not None:
                i = search(anim.draw_order.times, t)
                order = anim.draw_order.order(i) if i >= 0 else None
                if order is not None:
                    frame.order = list(order)
        # the sequence timelines read the attachments shown and change only which image they show
        frame.shown = [self.attachment(s, name) for s, name in enumerate(frame.names)]
        if animation is not None:
            for sq in anim.sequences:
                self._apply_sequence(sq, t, frame.shown, frame.sequence)
        self._deform(frame, range(n_slots), deforms)
        return frame

    def _bones_frame(self, animation: str, t: float, last: float) -> _Frame:
        """:meth:`_frame` of what poses the bones only: bone and constraint timelines, physics
        resets, and the attachment (and its deform) of each slot a path constraint follows."""
        anim, deforms = self.animation(animation)
        n_slots = len(self.slot_names)
        frame = _Frame(t, list(self.setup_local), list(self.setup_inherit), dict(self.setup_data),
                       list(self.slot_setup), [], [], [], [])
        active = self.active
        self._apply_bones(anim, t, frame.local, frame.inherit, active)
        self._apply_constraints(anim, t, frame.data)
        self._physics_resets(anim, last, t)
        frame.shown = [None] * n_slots
        if self.path_slots:
            self._apply_slots(anim, t, frame.names, None, active)
            for s in self.path_slots:
                frame.shown[s] = self.attachment(s, frame.names[s])
            self._deform(frame, self.path_slots, deforms)
        return frame

    def _deform(self, frame: _Frame, slots, deforms: dict) -> None:
        """The deformed vertices (where a deform timeline keys them) of ``slots``' shown attachments."""
        for s in slots:
            att = frame.shown[s]
            if att is not None and att.timeline_key in deforms:
                keys, values = deforms[att.timeline_key]
                i, p = keys.percent(frame.time)
                if i >= 0:
                    last_key = p == 0 or i == len(values) - 1
                    frame.deform[s] = values[i] if last_key else values[i] + (values[i + 1] - values[i]) * p

    def _physics_resets(self, anim: Animation, last: float, t: float) -> None:
        """4.2 reset keys passed since the last frame reset their constraints (all for "")."""
        for name, times in anim.physics_resets:
            if not _reset_fires(times, last, t):
                continue
            for c in self.rig.constraints:
                if c.kind == "physics" and c.physics is not None and c.active and name in ("", c.name):
                    c.physics.reset()

    def _apply_bones(self, anim: Animation, t: float, local: list, inherit: list, active: list,
                     carried: dict[int, float] | None = None) -> None:
        for k, tl in enumerate(anim.bones):
            if not active[tl.bone]:
                continue
            v = tl.keys.at(t)
            setup = self.setup_local[tl.bone]
            row = local[tl.bone]
            if row is setup:  # the first timeline of this bone: its own values from here on
                row = local[tl.bone] = list(setup)
            p = tl.property
            if p == "rotate":
                row[2] = carried[k] if carried and k in carried else setup[2] + (float(v[0]) if v is not None else 0.0)
            elif p in ("translate", "translatex", "translatey"):
                _set_pair(row, setup, v, p, 0, lambda s, k: s + k, 0.0)
            elif p in ("scale", "scalex", "scaley"):
                _set_pair(row, setup, v, p, 3, lambda s, k: s * k, 1.0)
            elif p in ("shear", "shearx", "sheary"):
                _set_pair(row, setup, v, p, 5, lambda s, k: s + k, 0.0)
        for tl in anim.inherits:
            i = search(tl.times, t)
            mode = tl.modes[i] if i >= 0 else self.setup_inherit[tl.bone]
            if active[tl.bone]:
                inherit[tl.bone] = mode if mode in ("normal", "onlyTranslation", "noRotationOrReflection",
                                                    "noScale", "noScaleOrReflection") else "normal"

    def _apply_constraints(self, anim: Animation, t: float, data: dict) -> None:
        for tl in anim.constraints:
            i = tl.keys.index(t)
            if i < 0:
                continue  # the setup values
            v = tl.keys.at(t)
            for c in self._keyed(tl):
                d = dict(data[id(c)])
                for key, value in zip(tl.fields, v):
                    d[key] = float(value)
                if tl.flags:
                    d.update(tl.flags[i])
                data[id(c)] = d

    def _keyed(self, tl) -> list:
        """The constraints a constraint timeline drives: the one it names; a 4.2 physics
        timeline without a name, every physics constraint whose ``<value>Global`` is set."""
        if tl.kind == "physics" and tl.name == "":
            return [c for c in self.rig.constraints
                    if c.kind == "physics" and c.data.get(f"{tl.fields[0]}Global") is True]
        c = self.constraints.get((tl.kind, tl.name))
        return [] if c is None else [c]

    def _apply_slots(self, anim: Animation, t: float, names: list, colors: list | None, active: list,
                     darks: list | None = None) -> None:
        """Attachment and colour timelines (``colors`` None: attachments only), the dark colours
        of two-colour timelines into ``darks`` (a slot without a setup dark colour keeps none:
        the runtimes have no dark colour to set there)."""
        for tl in anim.attachments:
            if not active[self.slot_bones[tl.slot]]:
                continue
            i = search(tl.times, t)
            names[tl.slot] = tl.names[i] if i >= 0 else self.slot_setup[tl.slot]
        # Colour channels are clamped to 0..1 (a Bezier can overshoot) where the runtime clamps
        # them: Color.set (rgba, rgba2's light) always, 3.8's dark colour (Color.set too), and
        # in 4.3 every channel a timeline sets; 4.0 to 4.2 assign the others as they are.
        clamp_light = self.colours_clamped
        clamp_dark = self.colours_clamped or not self.four
        for tl in anim.slots if colors is not None else ():
            v = tl.keys.at(t)
            setup = self.slot_color[tl.slot]
            c = colors[tl.slot]
            if c is setup:  # the slot's first colour timeline: its own colour from here on
                c = colors[tl.slot] = setup.copy()
            if tl.property in ("rgba", "rgba2"):
                c[:] = setup if v is None else np.clip(v[:4], 0.0, 1.0)
            elif tl.property in ("rgb", "rgb2"):
                c[:3] = setup[:3] if v is None else np.clip(v[:3], 0.0, 1.0) if clamp_light else v[:3]
            elif tl.property == "alpha":
                c[3] = setup[3] if v is None else min(max(float(v[0]), 0.0), 1.0) if clamp_light else float(v[0])
            dark = darks[tl.slot] if darks is not None and tl.property in ("rgba2", "rgb2") else None
            if dark is not None and dark is self.slot_dark[tl.slot]:
                dark = darks[tl.slot] = dark.copy()
            if dark is not None:  # the light part's curves drive it
                keyed = None if v is None else np.asarray(v[4:7] if tl.property == "rgba2" else v[3:6], float)
                dark[:] = self.slot_dark[tl.slot] if keyed is None else np.clip(keyed, 0, 1) if clamp_dark else keyed

    def _apply_sequence(self, sq, t: float, shown: list, sequence: list) -> None:
        att = shown[sq.slot]
        target = self.prepared(sq.skin, sq.slot, sq.attachment)
        if att is None or target is None or not target.sequence_count:
            return
        if att is not target and att.timeline_key != target.timeline_key:
            return
        i = search(sq.times, t)
        if i < 0:
            sequence[sq.slot] = -1
            return
        sequence[sq.slot] = _sequence_index(sq.frames, i, float(sq.times[i]), t, target.sequence_count)

    def _pose_bones(self, frame: _Frame, flagged: dict[int, str]):
        """World transforms (B, 2, 3) of the frame's bones, which are exact and why not.

        ``flagged``: bone index to the name of the physics constraint that moves it and is not
        stepped here (those bones and the bones below them are not exact)."""
        rig = self.rig
        self._step_bones(frame)
        world = np.array([b.m for b in rig.bones]).reshape(-1, 2, 3) if rig.bones else np.zeros((0, 2, 3))
        exact = np.array([b.exact for b in rig.bones], bool)
        why = {b.name: b.why for b in rig.bones if not b.exact}
        for b in rig.bones:
            name = flagged.get(b.index)
            parent_flag = b.parent is not None and not exact[b.parent.index]
            if name is not None or (parent_flag and exact[b.index]):
                exact[b.index] = False
                why.setdefault(b.name, f"moved by the physics constraint {name!r}, which is not simulated"
                               if name is not None else f"below {b.parent.name!r}: {why.get(b.parent.name, '')}")
        return world, exact, why

    def _step_bones(self, frame: _Frame) -> None:
        """The frame's bones posed (``updateWorldTransform``: constraints applied, physics
        stepped), their transforms left on the rig's bones."""
        rig = self.rig
        data, shown, deform_now = frame.data, frame.shown, frame.deform
        for b, values, mode in zip(rig.bones, frame.local, frame.inherit):
            b.local = values if type(values) is tuple else tuple(map(float, values))  # a tuple: the setup's floats
            b.inherit = mode
        for c in rig.constraints:
            c.data = data[id(c)]
            if c.kind == "path":
                s = self.slot_index.get(path_slot(self.setup_data[id(c)]))
                att = shown[s] if s is not None else None
                ok = att is not None and att.type == "path"
                c.path = self._path_json(att) if ok else None
                c.path_deform = list(deform_now[s]) if ok and s in deform_now else None
        update_world(rig)
        for b in rig.bones:
            if not b.active:  # not posed by the runtime without its skin: from its parent
                b.update_with(b.local)

    def _path_json(self, att: Prepared) -> dict | None:
        a = ((self.skins.get(att.skin) or {}).get(self.slot_names[att.slot]) or {}).get(att.key)
        return a if isinstance(a, dict) else None

    def _draw(self, world, frame: _Frame, active: list, placed: dict | None = None,
              like: dict | None = None) -> list[DrawnSlot]:
        """The frame's drawn attachments, placed with the bones' world transforms ``world``.

        ``placed``: filled with, per slot, ``(attachment, sequence frame, deform, vertices)``
        of what it placed. ``like``: ``placed`` of another sampler drawing the same bones
        (:meth:`play_pair`): a slot showing an attachment of the same numbers there, with
        the same deform, takes its vertices from there instead of computing them again (the
        upgraded skeleton keeps most attachments of its original as they are)."""
        shown, colors, deform_now, sequence = frame.shown, frame.colors, frame.deform, frame.sequence
        order = frame.order
        out: list[DrawnSlot] = []
        clip = None     # (polygon, end slot name)
        for s in order:
            att = shown[s]
            bone = self.slot_bones[s]
            if att is not None and active[bone]:
                if att.type == "clipping":
                    if clip is None:
                        poly = self._place(att, 0, world, bone, deform_now.get(s), s, placed, like)
                        clip = (poly, att.end_slot)
                    continue
                if att.type in ("region", "mesh"):
                    f = att.frame(sequence[s])
                    verts = self._place(att, f, world, bone, deform_now.get(s), s, placed, like)
                    uvs = att.uvs[f] if att.type == "region" else att.uvs
                    path = att.frame_paths[f] if att.frame_paths else att.path
                    out.append(DrawnSlot(self.slot_names[s], self.bone_names[bone], att.name, att.key, att.skin, path,
                                         att.type, self.slot_blend[s], colors[s] * att.rgba, verts, uvs,
                                         att.triangles, att.hull, None if clip is None else clip[0],
                                         dark=None if frame.darks[s] is None else frame.darks[s].copy()))
            if clip is not None and clip[1] == self.slot_names[s]:
                clip = None
        return out

    def _place(self, att: Prepared, f: int, world: np.ndarray, bone: int, deform: np.ndarray | None, slot: int,
               placed: dict | None, like: dict | None) -> np.ndarray:
        """World vertices (N, 2) of ``att`` (sequence frame ``f``) on ``slot``'s ``bone`` (see :meth:`_draw`)."""
        if like is not None:
            was = like.get(slot)
            if was is not None and was[1] == f and _same_numbers(was[2], deform):
                key = (id(was[0]), id(att))
                if key not in self._alike:  # the pair kept with the answer, so that neither id is reused
                    self._alike[key] = (was[0], att, _same_placing(was[0], att))
                if self._alike[key][2]:
                    return was[3]
        if att.type == "region":
            m = world[bone]
            verts = att.offsets[f] @ m[:, :2].T + m[:, 2]
        else:
            verts = att.geometry.world(world, bone, deform)
        if placed is not None:
            placed[slot] = (att, f, deform, verts)
        return verts


def _carried_rotations(anim: Animation, setup_local: list, active: list, time: float, fps: float,
                       loop: bool) -> dict[int, float]:
    """The angles of ``anim``'s carried 3.7 and 3.8 rotate timelines (``BoneTimeline.carried``) at track
    time ``time``, as the 3.7 and 3.8 runtimes reach them: from the setup pose, every step of the game
    loop adds to the bone's angle its keyed angle's difference from it brought within half a
    turn (``spinemesh.rig.transform.wrap_turns``), so the angle follows the keys the shorter way
    round and never jumps by a turn. By the timeline's place in ``anim.bones``; empty when no
    timeline is carried (the angle is then the keyed one, as every 4.x runtime sets it).

    Raises
    ------
    SpineMeshError
        Past :data:`~spinemesh.limits.MAX_POSE_STEPS` steps, each of which would be replayed.
    """
    timelines = [(k, tl) for k, tl in enumerate(anim.bones) if tl.carried and active[tl.bone]]
    if not timelines:
        return {}
    steps, dt = steps_of(time, fps)
    if steps > MAX_POSE_STEPS:
        raise SpineMeshError(f"{time:g} s is over {MAX_POSE_STEPS:,} game-loop steps, each of which turns a bone "
                             "the 3.7 and 3.8 runtimes carry from frame to frame")
    times, track = [], 0.0
    for i in range(steps + 1):
        if i:
            track += dt
        times.append(_track_to_animation(track, anim.duration, loop))
    out = {}
    for k, tl in timelines:
        setup = setup_local[tl.bone][2]
        angle = setup
        for t in times:
            v = tl.keys.at(t)
            # the runtime's order of operations: at 1e12 degrees a rounding apart is 5e-4 world units
            angle += wrap_turns((float(v[0]) if v is not None else 0.0) + (setup - angle))
        out[k] = angle
    return out


def _same_numbers(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two arrays (or None) hold the same numbers bit for bit (0.0 and -0.0 told apart)."""
    if a is None or b is None:
        return a is b
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _same_placing(a: Prepared, b: Prepared) -> bool:
    """Whether attachments ``a`` and ``b`` place their vertices from the same numbers: with the
    same bone transforms and deform, the same vertices to the last bit."""
    if a.type != b.type:
        return False
    if a.type == "region":
        return _same_numbers(a.offsets, b.offsets)
    ga, gb = a.geometry, b.geometry
    if ga is None or gb is None or ga.weighted != gb.weighted or ga.count != gb.count:
        return False
    if not ga.weighted:
        return _same_numbers(ga.local, gb.local)
    return all(_same_numbers(x, y) for x, y in ((ga.local, gb.local), (ga.bone, gb.bone), (ga.vertex, gb.vertex),
                                                (ga.weight, gb.weight)))


def _ascending(times) -> list[float]:
    """``times`` as floats; a ValueError where one comes before the time before it."""
    times = [float(t) for t in times]
    if any(b < a for a, b in itertools.pairwise(times)):
        raise ValueError("times must be ascending")
    return times


def _nearest_steps(times: list[float], fps: float) -> list[int]:
    """The game-loop step (of ``1 / fps`` s from 0) nearest to each time, as a player shows it."""
    return [max(0, math.floor(t * fps + 0.5)) if math.isfinite(t) else 0 for t in times]


#: Keys of an animation that hold attachments' timelines (deform, sequence), by version.
_ATTACHMENT_TIMELINES = ("deform", "ffd", "attachments")


def _motion_view(doc: dict) -> dict:
    """What of a skeleton document moves its bones: everything but the attachments (and their
    deform and sequence timelines), those of path constraints' target slots kept (a path
    constraint follows the path attachment its slot shows)."""
    targets = {path_slot(c) for c in constraints_of(doc, "path")}

    def kept(by_slot):
        return {k: v for k, v in by_slot.items() if str(k) in targets} if isinstance(by_slot, dict) else by_slot

    skins = doc.get("skins")
    if isinstance(skins, list):  # 3.8+: [{name, attachments, bones, ...}]
        skins = [{k: kept(v) if k == "attachments" else v for k, v in s.items()} if isinstance(s, dict) else s
                 for s in skins]
    elif isinstance(skins, dict):  # 3.5-3.7: {name: {slot: {attachment: ...}}}
        skins = {name: kept(by_slot) for name, by_slot in skins.items()}
    animations = doc.get("animations")
    if isinstance(animations, dict):
        animations = {name: {k: ({skin: kept(by_slot) for skin, by_slot in v.items()}
                                 if k in _ATTACHMENT_TIMELINES and isinstance(v, dict) else v)
                             for k, v in a.items()} if isinstance(a, dict) else a
                      for name, a in animations.items()}
    return {**doc, "skins": skins, "animations": animations}


def same_motion(a: dict, b: dict) -> bool:
    """Whether the bones of skeleton documents ``a`` and ``b`` move alike in every animation and
    skin: the same bones, constraints, skins' bone and constraint lists, physics settings,
    bone, constraint, slot and draw order timelines, and the same path attachments (with
    their timelines) where a path constraint reads them. An upgrade changes attachments
    only, so an upgraded skeleton moves as its original: its poses can share the original's
    bone transforms (:meth:`Sampler.play_pair`). A value that is not a number (NaN) compares
    unequal to itself: such documents are not taken as alike.

    Examples
    --------
    >>> a = {"bones": [{"name": "root"}], "skins": [{"name": "default", "attachments": {"s": {"r": {}}}}]}
    >>> same_motion(a, {**a, "skins": [{"name": "default", "attachments": {"s": {"r": {"type": "mesh"}}}}]})
    True
    >>> same_motion(a, {**a, "bones": [{"name": "root", "x": 1}]})
    False
    """
    return _motion_view(a) == _motion_view(b)


def _js_sign(x: float) -> float:
    return 1.0 if x > 0 else -1.0 if x < 0 else x


class SliderPlayer:
    """A 4.3 slider's update: its animation applied, in the middle of the update cache, over the
    bones' current values at the slider's time (keyed, or read from a bone's property) and mix,
    replacing or (``additive``) adding, as spine-core 4.3's ``Slider`` applies it
    (``MixFrom.current``). Bone timelines only (:func:`spinemesh.rig.constraints.families.slider_played`)."""

    def __init__(self, sampler: Sampler, data: dict):
        self.anim = sampler.animation(str(data.get("animation")))[0]
        self.setup = sampler.setup_local

    def update(self, c) -> bool:
        """Apply the slider ``c`` (the rig's constraint: ``data``, driving bone ``target``, posed
        ``bones``); False where the runtime returns first."""
        d = c.data
        mix = _number(d.get("mix", 1), 1.0)
        if mix == 0:
            return False
        loop, duration = d.get("loop") is True, self.anim.duration
        time = _number(d.get("time", 0), 0.0)
        bone = c.target
        if bone is not None:
            if not bone.active:
                return False
            local = d.get("local") is True
            if local:
                bone.validate_local()
            value = source_value_43(PROPERTIES.index(d.get("property")), bone, local, [0.0] * 6)
            offset, start = _number(d.get("to", 0), 0.0), _number(d.get("from", 0), 0.0)
            time = offset + (value - start) * _number(d.get("scale", 1), 1.0)
            time = duration + math.fmod(time, duration) if loop else max(0.0, time)
        for b in c.bones:
            b.modify_local()
        if loop and duration != 0:
            time = math.fmod(time, duration)
        add = d.get("additive") is True
        bones = {b.index: b for b in c.bones}
        for tl in self.anim.bones:
            b = bones.get(tl.bone)
            if b is not None and b.active:
                _mix_current(tl.property, tl.keys.at(time), b.applied, self.setup[tl.bone], mix, add)
        return True


def _mix_current(prop: str, v, a: list, setup: tuple, alpha: float, add: bool) -> None:
    """One bone timeline's value ``v`` (None before its first key: nothing changes) mixed into
    the bone's current values ``a`` by ``alpha`` from where they are, or added (``add``)."""
    if v is None:
        return
    pairs = {"translate": (0, 1), "translatex": (0,), "translatey": (1,), "rotate": (2,), "scale": (3, 4),
             "scalex": (3,), "scaley": (4,), "shear": (5, 6), "shearx": (5,), "sheary": (6,)}[prop]
    for k, i in enumerate(pairs):
        value = float(v[k])
        if i in (3, 4):  # scales multiply the setup value
            value *= setup[i]
            if alpha == 1 and not add:
                a[i] = value
            elif add:
                a[i] = a[i] + (value - setup[i]) * alpha
            else:
                base = abs(a[i]) * _js_sign(value)
                a[i] = base + (value - base) * alpha
        else:
            a[i] = a[i] + (value if add else value + setup[i] - a[i]) * alpha


def _reset_fires(times: np.ndarray, last: float, t: float) -> bool:
    """Whether a reset key lies in (``last``, ``t``], across the loop when ``last > t``
    (``PhysicsConstraintResetTimeline``)."""
    if last > t:
        if _reset_fires(times, last, math.inf):
            return True
        last = -1.0
    elif last >= times[-1]:
        return False
    if t < times[0]:
        return False
    if last < times[0]:
        return True
    i = search(times, last)
    return i + 1 < len(times) and t >= times[i + 1]


def _set_pair(row: list, setup: tuple, v, prop: str, at: int, combine, neutral: float) -> None:
    """Set x and/or y of a translate/scale/shear pair starting at ``row[at]``."""
    if prop.endswith("x"):
        row[at] = combine(setup[at], float(v[0]) if v is not None else neutral)
    elif prop.endswith("y"):
        row[at + 1] = combine(setup[at + 1], float(v[0]) if v is not None else neutral)
    else:
        row[at] = combine(setup[at], float(v[0]) if v is not None else neutral)
        row[at + 1] = combine(setup[at + 1], float(v[1]) if v is not None else neutral)


_SEQUENCE_MODES = ("hold", "once", "loop", "pingpong", "onceReverse", "loopReverse", "pingpongReverse")


def _sequence_index(frames: list[dict], i: int, before: float, t: float, count: int) -> int:
    """4.1+ ``SequenceTimeline``: the frame shown ``t - before`` seconds after key ``i``."""
    delay = 0.0
    for f in frames[:i + 1]:  # a key without delay keeps the one before
        if "delay" in f:
            delay = _number(f["delay"], delay)
    key = frames[i]
    index = int(_number(key.get("index", 0), 0))
    mode = key.get("mode", "hold")
    mode = mode if mode in _SEQUENCE_MODES else "hold"
    if mode == "hold":
        return index
    if delay > 0:
        index += int((t - before) / delay + 0.00001)
    if mode == "once":
        return min(count - 1, index)
    if mode == "loop":
        return index % count
    if mode == "pingpong":
        n = (count << 1) - 2
        index = 0 if n == 0 else index % n
        return n - index if index >= count else index
    if mode == "onceReverse":
        return max(count - 1 - index, 0)
    if mode == "loopReverse":
        return count - 1 - (index % count)
    n = (count << 1) - 2
    index = 0 if n == 0 else (index + count - 1) % n
    return n - index if index >= count else index


def atlas_regions(atlases) -> callable:
    """``regions(path)`` for :class:`Sampler` from parsed atlases (:class:`spinemesh.atlas.Atlas`,
    one or a list): the first atlas holding the region wins, as an attachment loader finds it."""
    atlases = [atlases] if not isinstance(atlases, (list, tuple)) else list(atlases)
    cache: dict[str, RegionGeometry | None] = {}

    def regions(path: str) -> RegionGeometry | None:
        if path not in cache:
            cache[path] = None
            for atlas in atlases:
                r = atlas.find(path)
                if r is None:
                    continue
                try:
                    g = r.geometry()
                except SpineMeshError:  # a malformed region: drawn as if stored whole
                    break
                cache[path] = RegionGeometry(g.width, g.height, g.offset_x, g.offset_y, g.original_width,
                                             g.original_height)
                break
        return cache[path]
    return regions
