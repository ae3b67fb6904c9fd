"""A fitted linear blend skin (gencoords.skinning.skin_fit) against GenCoords' deformation.

Issue 26's scene: Suzanne subdivided twice (7,958 vertices, made with bpy) in a
162-vertex icosphere cage, mean value coordinates, the cage keyframed through a twist
about Z and then a squash along Z over 24 frames; the mesh's positions at each frame are
the coordinates times the cage. The skin is fitted with 4 influences and at most 255
bones, once on all 24 frames and once on every other frame (the others held out: their
bone transforms solved with the weights fixed, as a rig replays poses it was not fitted
on). Printed: worst and RMS distance to GenCoords' positions as fractions of the mesh's
bounding-box diagonal, and the fit's time (noisy on a shared machine).

The same on the character (tests/fixtures/character.py: a non-convex, box-modelled T-pose
cage of 196 vertices, mean value coordinates partly negative there) around its capsule
body at about 8,000 vertices, the cage animated over 24 frames: the arms bend up from the
shoulders (up to 60 degrees at the hands), the legs swing forward and back from the hips
(30 degrees at the feet) and the head turns (40 degrees).

    .venv/bin/python scripts/benchmarks/bench_skin_fit.py [--bones 64] [--iterations 12]
        [--scene suzanne|character|both]
"""

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir))  # the repository
from scripts.common import session  # noqa: E402

FRAMES = 24


def suzanne_vertices(level=2):
    """Suzanne as the other benchmarks make her (scripts/common/scenes.py), (n, 3)."""
    session.prepare()
    from scripts.common import scenes
    scenes.reset_scene()
    obj = scenes.add_suzanne(level)
    return scenes.arrays.read_positions(obj.data).astype(np.float64)


def twist_and_squash(cage, frames=FRAMES):
    """The cage at each frame ((frames, n, 3)): the first half twists it about Z (up to
    90 degrees at the top, -90 at the bottom), the second half squashes the twisted cage
    along Z (to 60 %, widening 1.2x)."""
    height = np.ptp(cage[:, 2])
    poses = []
    for frame in range(1, frames + 1):
        twist = min(frame / (frames / 2), 1.0)
        squash = max(frame - frames / 2, 0.0) / (frames / 2)
        angle = twist * 0.5 * np.pi * cage[:, 2] / (0.5 * height)
        c, s = np.cos(angle), np.sin(angle)
        x, y = c * cage[:, 0] - s * cage[:, 1], s * cage[:, 0] + c * cage[:, 1]
        widen = 1.0 + 0.2 * squash
        poses.append(np.column_stack([x * widen, y * widen, cage[:, 2] * (1.0 - 0.4 * squash)]))
    return np.array(poses)


def turn(points, pivot, axis, angles):
    """``points`` ((n, 3)) turned by ``angles`` ((n,) radians) about ``axis`` (0, 1, 2)
    through ``pivot``."""
    a, b = [k for k in range(3) if k != axis]
    moved = points.copy()
    u, v = points[:, a] - pivot[a], points[:, b] - pivot[b]
    moved[:, a] = pivot[a] + np.cos(angles) * u - np.sin(angles) * v
    moved[:, b] = pivot[b] + np.sin(angles) * u + np.cos(angles) * v
    return moved


def character_motion(cage, frames=FRAMES):
    """The character's cage at each frame ((frames, n, 3)): arms, legs and head."""
    x, z = cage[:, 0], cage[:, 2]
    poses = []
    for frame in range(1, frames + 1):
        amount = np.sin(0.5 * np.pi * frame / frames)
        arm = np.clip((np.abs(x) - 0.2) / 0.75, 0.0, 1.0) * (z > 1.2)
        pose = turn(cage, np.array([0.0, 0.0, 1.325]), 1, -np.sign(x) * arm * np.radians(60) * amount)
        leg = np.clip((0.8 - z) / 0.8, 0.0, 1.0) * (np.abs(x) > 0.05)
        pose = turn(pose, np.array([0.0, 0.0, 0.8]), 0, np.sign(x) * leg * np.radians(30) * amount)
        head = np.clip((z - 1.4) / 0.35, 0.0, 1.0)
        poses.append(turn(pose, np.zeros(3), 2, head * np.radians(40) * amount))
    return np.array(poses)


def suzanne_scene():
    """Suzanne in a 162-vertex icosphere: (label, rest (n, 3), coordinates, cage, cage poses)."""
    import gencoords
    from gencoords.surfaces.named import MEAN_VALUE
    from gencoords.cages import shapes
    rest = suzanne_vertices()
    cage, faces = shapes.icosphere(2, radius=2.0)
    coordinates = gencoords.coordinates(rest, cage, faces, kind=MEAN_VALUE)
    label = f"Suzanne {len(rest)} vertices, icosphere cage {len(cage)} vertices, twist and squash"
    return label, rest, coordinates, cage, twist_and_squash(cage)


def character_scene():
    """The character's body in its cage: (label, rest, coordinates, cage, cage poses)."""
    import gencoords
    from gencoords.surfaces.named import MEAN_VALUE
    from gencoords.cages import triangulate_quads
    from tests.fixtures import character
    rest, _, _ = character.body_mesh(detail=0.42)
    cage, quads = character.character_cage()
    coordinates = gencoords.coordinates(rest, cage, triangulate_quads(cage, quads), kind=MEAN_VALUE)
    label = (f"character body {len(rest)} vertices, non-convex cage {len(cage)} vertices, "
             "arms, legs and head")
    return label, rest, coordinates, cage, character_motion(cage)


def report(label, rest, frames, fit, skin_fit):
    worst, rms = skin_fit.deviations(rest, frames, fit)
    print(f"  {label:<30} worst {100 * worst:6.3f} %   RMS {100 * rms:6.3f} % of the diagonal")
    return worst, rms


def timed_fit(rest, frames, args, label):
    from gencoords.skinning import skin_fit
    start = time.perf_counter()
    fit = skin_fit.fit_skin(rest, frames, bones=args.bones, max_influences=args.influences,
                            iterations=args.iterations)
    seconds = time.perf_counter() - start
    print(f"fit on {label}: {seconds:.1f} s, {fit.transforms.shape[1]} bones kept")
    return fit


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bones", type=int, default=64)
    parser.add_argument("--iterations", type=int, default=12)
    parser.add_argument("--influences", type=int, default=4)
    parser.add_argument("--scene", choices=("suzanne", "character", "both"), default="both")
    args = parser.parse_args()

    scenes = {"suzanne": suzanne_scene, "character": character_scene}
    for name in (scenes if args.scene == "both" else [args.scene]):
        fit_scene(*scenes[name](), args)


def fit_scene(label, rest, coordinates, cage, cage_poses, args):
    from gencoords.skinning import skin_fit, skinning
    frames = coordinates @ cage_poses
    print(f"\n{label}: mean value ({100 * np.mean(coordinates < -1e-9):.1f} % negative), "
          f"{len(frames)} frames; {args.influences} influences, {args.bones} bones seeded, "
          f"{args.iterations} iterations")
    # The baseline, in the same run: a bone per cage vertex, the coordinates truncated
    # to the largest few (what 4 influences of a Bone per Cage Vertex bake play).
    truncated = rest + skinning.truncate(coordinates, args.influences) @ (cage_poses - cage)
    gaps = np.linalg.norm(truncated - frames, axis=2) / np.linalg.norm(np.ptp(rest, axis=0))
    print(f"  {'bone per cage vertex, truncated':<30} worst {100 * gaps.max():6.3f} %   "
          f"RMS {100 * np.sqrt(np.mean(gaps ** 2)):6.3f} % of the diagonal")
    fit = timed_fit(rest, frames, args, f"all {FRAMES} frames")
    report("fitted frames", rest, frames, fit, skin_fit)
    fitted, held = frames[0::2], frames[1::2]
    half = timed_fit(rest, fitted, args, f"the {len(fitted)} odd frames")
    report("fitted (odd) frames", rest, fitted, half, skin_fit)
    transforms = skin_fit.fit_transforms(rest, held, half.indices, half.weights)
    held_fit = skin_fit.SkinFit(half.rest_matrices, transforms, half.indices, half.weights)
    report("held-out (even) frames", rest, held, held_fit, skin_fit)


if __name__ == "__main__":
    main()
