"""The setup pose with its constraints applied, as the official runtimes 3.8 to 4.3 compute it.

One module per idea: :mod:`.families` (which runtime family poses a skeleton, and its
constraints of each kind), :mod:`.pose_bone` (a bone as the update cache poses it), one module
per constraint kind (:mod:`.ik`, :mod:`.transform_constraint`, :mod:`.path`; physics is
:mod:`spinemesh.rig.physics`), and :mod:`.solver`, the update cache built and played once
(:func:`.solver.setup_pose`, :func:`.solver.build_rig`, :func:`.solver.update_world`). Callers
import from the module that holds a name (this package re-exports nothing).

A game that loads a skeleton sets it to the setup pose and calls ``updateWorldTransform``
once: the runtime walks an *update cache*, a list of bones and constraints sorted once per
skeleton, in which every constraint comes after the bones it reads and every bone a
constraint moves is updated again after it. This package builds that list the way each
runtime family builds it (3.8, 4.0, 4.1, 4.2 differ in details noted where they matter),
then plays it once: bones take their world transform from their parent; IK constraints
(one and two bones: mix, bend direction, compress, stretch, uniform, softness) turn and
scale their bones towards the target; transform constraints (world or local, absolute or
relative) pull their bones' transforms towards the target's; path constraints (position,
spacing and rotate modes, constant speed or not, open or closed paths) lay their bones along
the target slot's path.

4.3 skeletons are posed in the family :func:`.families.posing_family` names, by :func:`.solver.setup_pose` and
:class:`spinemesh.anim.Sampler` alike: 4.3 transform constraints map properties
(:mod:`..transform43`), and 4.3 bones take their local values back from a changed world transform
lazily, as 4.3 does.

Each bone carries an *exact* flag. A 3.8 path constraint the 3.8 runtimes lay apart
(:func:`.solver.lays_apart_38`: the official one, which this package follows, and pixi-spine's port)
leaves its bones not exact in :func:`.solver.setup_pose`, the pose bindings are made in (the sampler's
poses are the official runtime's, exact). A constraint only some skins activate, a 4.3 skeleton with a constraint :func:`.families.posing_family` does not solve,
a slider without its player (the sampler's: :func:`.solver.setup_pose` has none), or one older than 3.8
(no runtime to check against) leaves the bones it moves not
exact, with the reason, and so does any constraint that reads a bone that is not exact;
children of a bone that is not exact are not exact. Physics constraints (4.2, 4.3) leave the
setup pose as it is. The math follows the public runtime sources (EsotericSoftware
spine-runtimes, spine-ts); the implementation is ours.
"""
