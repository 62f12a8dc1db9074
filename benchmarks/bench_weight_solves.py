"""The bounded biharmonic weights' QPs of real upgrades, solved by PIQP and by exact alternatives.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_weight_solves.py [--projects A,B,...]
        [--corpus DIR] [--record FILE] [--per-mesh | --other-solvers [--budget S]]

Each corpus project of ``--projects`` (default dq-symbols and kraken-symbols) is upgraded with
``--weights auto`` (``--jobs 1``, into a temporary folder) and the input of every call of
:func:`spinemesh.rig.weights.bounded_biharmonic` is recorded (``--record FILE`` keeps them, and
reads them back instead of upgrading when the file exists). Each call with handles on two bones
or more is one QP per solved bone: ``min x^T Q x / 2 + c^T x`` subject to ``0 <= x <= 1``, the
same ``Q`` (shape (F, F), F free points of the refinement) for every bone of a mesh. Solved by:

- PIQP as shipped (tolerance ``SOLVER_TOLERANCE``), and with tolerances of 1e-10 (duality gap
  1e-12): the *reference*, the optimum every other answer is compared with;
- PIQP with 3 or 2 rounds of Ruiz equilibration instead of its 10 (the same tolerance);
- the unconstrained minimiser (one sparse LU of ``Q`` for all bones of a mesh): the optimum
  itself wherever it lies inside [0, 1];
- projected Newton from the clipped unconstrained minimiser (a Newton step on the points no
  bound holds, a backtracking search along its projection onto the box; at most 30 steps);
- a primal-dual active set (exact: the answer is the optimum when the sets settle, within 50
  steps; one sparse LU of the free points' ``Q`` per step), started from the unconstrained
  minimiser's sets, and from the sets PIQP's own answer makes active.

Printed: QPs solved, CPU seconds (one thread), factorisations, and the largest and the 99th
percentile of ``|x - reference|`` over the QPs each method solved.

``--other-solvers`` prints instead PIQP beside the other open-source sparse QP solvers that
take box bounds, where installed (``pip install clarabel osqp proxsuite highspy``: Clarabel,
Apache-2.0, interior point; OSQP, Apache-2.0, ADMM; ProxQP, BSD-2-Clause, proximal augmented
Lagrangian; HiGHS, MIT, active set), each given ``--budget`` CPU seconds: the QPs it solved
within them by its own account (an answer it reports unsolved or cut short counts as none), its
CPU per QP tried, and how far its answers lie from the reference.

``--per-mesh`` prints instead the CPU per mesh (all its bones) of the weights that need no QP
beside PIQP's: harmonic weights (one sparse solve, libigl) and geodesic weights (one Dijkstra,
:func:`spinemesh.rig.weights.geodesic_weights`), on the same recorded meshes.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.rig import weights as rig_weights  # noqa: E402

CORPUS = REPO.parent / "shared" / "spine-corpus"

#: Most steps of the active-set method before it counts as unsettled.
ACTIVE_SET_STEPS = 50

#: Steps a method warm-started and falling back to PIQP could afford (PIQP: about 19 iterations).
QUICK_STEPS = 5


def record(projects: list[Path]) -> list[tuple]:
    """``(v, f, b, bc)`` of every :func:`bounded_biharmonic` call of ``upgrade --weights auto``."""
    from spinemesh.upgrade import Options, upgrade_project

    calls, solve = [], rig_weights.bounded_biharmonic

    def kept(v, f, b, bc):
        calls.append((v.copy(), f.copy(), b.copy(), bc.copy()))
        return solve(v, f, b, bc)

    rig_weights.bounded_biharmonic = kept
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for project in projects:
                upgrade_project(project, Path(tmp) / project.name, Options(jobs=1, weights="auto"))
    finally:
        rig_weights.bounded_biharmonic = solve
    return calls


def qps(calls: list[tuple]) -> list[tuple]:
    """``(Q_free, C)`` per call with two or more bones' handles: C's columns the bones solved."""
    out = []
    for v, f, b, bc in calls:
        bones = [j for j in range(bc.shape[1]) if bc[:, j].any()]
        free = np.setdiff1d(np.arange(len(v)), b)
        if len(bones) < 2 or not len(free):
            continue
        qp = rig_weights.biharmonic_qp(v, f, free, b)
        if qp is not None:
            solved = bones[:1] if len(bones) == 2 else bones  # as bounded_biharmonic: 1 - w for two
            out.append((qp[0], np.asarray(qp[1] @ bc[:, solved])))
    return out


def lu(q):
    """Sparse LU of a symmetric positive definite matrix (symmetric ordering, no pivoting)."""
    from scipy.sparse.linalg import splu

    return splu(q.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})


def active_set(q, c: np.ndarray, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray | None, int]:
    """Primal-dual active set for ``min x^T q x / 2 + c^T x``, ``0 <= x <= 1`` from the sets
    ``low`` (x = 0) and ``high`` (x = 1): the optimum and the factorisations made, or None where
    the sets do not settle within ``ACTIVE_SET_STEPS`` or come back to earlier ones."""
    seen, tol_x, tol_g = set(), 1e-9, 1e-8 * max(float(np.abs(c).max()), 1e-300)
    for step in range(1, ACTIVE_SET_STEPS + 1):
        free = np.flatnonzero(~(low | high))
        x = high.astype(float)
        if len(free):
            x[free] = lu(q[free][:, free]).solve(-c[free] - q[free][:, high] @ np.ones(int(high.sum())))
        g = q @ x + c
        inside = ~(low | high)
        new_low = (low & (g > -tol_g)) | (inside & (x < -tol_x))
        new_high = (high & (g < tol_g)) | (inside & (x > 1 + tol_x))
        if (new_low == low).all() and (new_high == high).all():
            return np.clip(x, 0.0, 1.0), step
        key = (new_low.tobytes(), new_high.tobytes())
        if key in seen:
            break
        seen.add(key)
        low, high = new_low, new_high
    return None, step


def projected_newton(q, c: np.ndarray, x: np.ndarray, steps: int = 30) -> tuple[np.ndarray | None, int]:
    """Projected Newton for the same QP from ``x`` clipped to [0, 1]: a Newton step on the points
    not held at a bound by their gradient, then a backtracking line search along its projection
    onto the box; the optimum and the factorisations made, or None when not settled in ``steps``."""
    x = np.clip(x, 0.0, 1.0)
    tol_g = 1e-8 * max(float(np.abs(c).max()), 1e-300)

    def energy(y):
        return 0.5 * y @ (q @ y) + c @ y

    fx = energy(x)
    for step in range(steps):
        g = q @ x + c
        held = ((x <= 0) & (g > 0)) | ((x >= 1) & (g < 0))
        free = np.flatnonzero(~held)
        wrong = ((x <= 0) & (g < -tol_g)) | ((x >= 1) & (g > tol_g))
        if np.abs(g[free]).max(initial=0.0) <= tol_g and not wrong.any():
            return x, step
        d = np.zeros_like(x)
        d[free] = lu(q[free][:, free]).solve(-g[free])
        a = 1.0
        while True:
            y = np.clip(x + a * d, 0.0, 1.0)
            fy = energy(y)
            if fy <= fx + 1e-4 * (g @ (y - x)) or a < 1e-10:
                break
            a /= 2
        x, fx = y, fy
    return None, steps


def _clarabel(q, c: np.ndarray) -> np.ndarray | None:
    import clarabel
    from scipy import sparse

    n = q.shape[0]
    box = sparse.vstack([sparse.eye(n), -sparse.eye(n)], format="csc")  # x <= 1, -x <= 0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-10
    solver = clarabel.DefaultSolver(sparse.triu(q, format="csc"), np.ascontiguousarray(c), box,
                                    np.concatenate([np.ones(n), np.zeros(n)]), [clarabel.NonnegativeConeT(2 * n)],
                                    settings)
    answer = solver.solve()
    return np.asarray(answer.x) if answer.status == clarabel.SolverStatus.Solved else None


def _osqp(q, c: np.ndarray) -> np.ndarray | None:
    import osqp
    from scipy import sparse

    n = q.shape[0]
    solver = osqp.OSQP()
    solver.setup(P=sparse.triu(q, format="csc"), q=np.ascontiguousarray(c), A=sparse.eye(n, format="csc"),
                 l=np.zeros(n), u=np.ones(n), verbose=False, eps_abs=1e-7, eps_rel=1e-7, max_iter=20000,
                 polishing=True)
    answer = solver.solve()
    return answer.x if answer.info.status_val == 1 else None  # 1: solved (not "solved inaccurate", not the limit)


def _proxqp(q, c: np.ndarray) -> np.ndarray | None:
    import proxsuite
    from scipy import sparse

    n = q.shape[0]
    solver = proxsuite.proxqp.sparse.QP(n, 0, n)  # the box as n inequalities of the identity
    solver.settings.eps_abs, solver.settings.eps_rel, solver.settings.verbose = 1e-7, 0.0, False
    solver.init(sparse.csc_matrix(q), np.ascontiguousarray(c), None, None, sparse.eye(n, format="csc"),
                np.zeros(n), np.ones(n))
    solver.solve()
    solved = solver.results.info.status == proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED
    return np.asarray(solver.results.x) if solved else None


def _highs(q, c: np.ndarray, seconds: float = 60.0) -> np.ndarray | None:
    import highspy
    from scipy import sparse

    n = q.shape[0]
    lp = highspy.HighsLp()
    lp.num_col_, lp.num_row_ = n, 0
    lp.col_cost_, lp.col_lower_, lp.col_upper_ = np.ascontiguousarray(c), np.zeros(n), np.ones(n)
    lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    lp.a_matrix_.start_ = np.zeros(n + 1, dtype=np.int32)
    hessian, lower = highspy.HighsHessian(), sparse.tril(q, format="csc")
    hessian.dim_, hessian.format_ = n, highspy.HessianFormat.kTriangular
    hessian.start_, hessian.index_, hessian.value_ = lower.indptr, lower.indices, lower.data
    model = highspy.HighsModel()
    model.lp_, model.hessian_ = lp, hessian
    solver = highspy.Highs()
    solver.setOptionValue("output_flag", False)
    solver.setOptionValue("time_limit", seconds)  # one QP can take minutes: the budget holds it
    solver.passModel(model)
    solver.run()
    if solver.getModelStatus() != highspy.HighsModelStatus.kOptimal:
        return None
    return np.asarray(solver.getSolution().col_value)


#: The other solvers of ``--other-solvers``: (row name, module, one QP's solve).
OTHER_SOLVERS = (
    ("Clarabel (interior point, tolerances 1e-10)", "clarabel", _clarabel),
    ("OSQP (ADMM, tolerance 1e-7, polished)", "osqp", _osqp),
    ("ProxQP (proximal augmented Lagrangian, tolerance 1e-7)", "proxsuite", _proxqp),
    ("HiGHS (active set)", "highspy", _highs),
)


def other_solvers(problems: list[tuple], budget: float) -> dict[str, tuple]:
    """``rows`` entries (answers, CPU s, "-", QPs tried) of each installed solver of ``OTHER_SOLVERS``,
    solving the QPs in order until ``budget`` CPU seconds are spent (None for the rest)."""
    import importlib.util

    rows = {}
    for name, module, solve in OTHER_SOLVERS:
        if importlib.util.find_spec(module) is None:
            print(f"{name}: not installed (pip install {module})")
            continue
        answers, t, tried = [], time.process_time(), 0
        for q, c in problems:
            for j in range(c.shape[1]):
                left = budget - (time.process_time() - t)
                tried += left > 0
                answers.append(None if left <= 0 else solve(q, c[:, j], left) if solve is _highs else solve(q, c[:, j]))
        rows[f"{name}, QPs begun within {budget:g} CPU s"] = (answers, time.process_time() - t, "-", tried)
    return rows


def per_mesh(calls: list[tuple]) -> str:
    """A table of the CPU seconds (one thread) that PIQP's bounded biharmonic weights, harmonic
    weights and geodesic weights take on the recorded meshes with handles on two bones or more."""
    import igl

    meshes = [(v, f, b, bc) for v, f, b, bc in calls if np.count_nonzero(bc.any(axis=0)) >= 2]
    methods = {
        "bounded biharmonic (PIQP, shipped)": lambda v, f, b, bc: rig_weights.bounded_biharmonic(v, f, b, bc),
        "harmonic (one sparse solve)": lambda v, f, b, bc: igl.harmonic(v, f, b, bc, 1),
        f"geodesic (falloff {rig_weights.GEODESIC_FALLOFF:g})": lambda v, f, b, bc: rig_weights.geodesic_weights(
            v, f, {int(i): int(j) for i, j in zip(b, bc.argmax(axis=1))}, bc.shape[1]),
    }
    cpu = {}
    for name, solve in methods.items():
        solve(*meshes[0])  # imports and first-call costs left out
        t = time.process_time()
        for mesh in meshes:
            solve(*mesh)
        cpu[name] = time.process_time() - t
    base = next(iter(cpu.values()))
    lines = [f"{len(meshes)} meshes with handles on two bones or more (median "
             f"{int(np.median([len(m[0]) for m in meshes]))} points)\n",
             "| weights | CPU s | per mesh ms | / PIQP |", "|---|--:|--:|--:|"]
    lines += [f"| {name} | {t:.2f} | {1000 * t / len(meshes):.1f} | {t / base:.3f} |" for name, t in cpu.items()]
    return "\n".join(lines)


def exact_methods(problems: list[tuple], rows: dict[str, tuple]) -> str:
    """Add the unconstrained minimiser, projected Newton and the primal-dual active set to ``rows``;
    the line saying how far the unconstrained minimiser leaves [0, 1]."""
    t, inside, outside, overshoot = time.process_time(), [], [], []
    for q, c in problems:
        x = lu(q).solve(-c)
        inside += [x[:, k] if (x[:, k] >= -1e-9).all() and (x[:, k] <= 1 + 1e-9).all() else None
                   for k in range(c.shape[1])]
        outside += list(((x < -1e-9) | (x > 1 + 1e-9)).sum(axis=0))
        overshoot += list(np.maximum(-x, x - 1).max(axis=0))
    rows["unconstrained minimiser, where inside [0, 1]"] = (inside, time.process_time() - t, len(problems))
    unconstrained_line = (f"the unconstrained minimiser: points outside [0, 1] median {np.median(outside):.0f}, "
                          f"beyond the bounds by median {np.median(overshoot):.2f}, most {max(overshoot):.2f}")

    t, answers, factorisations, settled = time.process_time(), [], 0, []
    for q, c in problems:
        start = lu(q).solve(-c)
        factorisations += 1
        for j in range(c.shape[1]):
            x, steps = projected_newton(q, c[:, j], start[:, j])
            answers.append(x)
            factorisations += steps
            if x is not None:
                settled.append(steps)
    rows[f"projected Newton from the clipped unconstrained minimiser ({sum(s <= QUICK_STEPS for s in settled)} "
         f"settled within {QUICK_STEPS} steps, {min(settled, default=0)} to {max(settled, default=0)} steps)"] = (
        answers, time.process_time() - t, factorisations)

    shipped = next(iter(rows.values()))[0]
    for name, start in (("from the unconstrained minimiser", None), ("from PIQP's answer", 0)):
        t, answers, factorisations, k, quick = time.process_time(), [], 0, 0, 0
        for q, c in problems:
            unconstrained = lu(q).solve(-c) if start is None else None
            factorisations += start is None
            for j in range(c.shape[1]):
                if start is None:
                    low, high = unconstrained[:, j] < 0, unconstrained[:, j] > 1
                else:
                    low, high = shipped[k] < 1e-6, shipped[k] > 1 - 1e-6  # PIQP's own time not counted
                x, steps = active_set(q, c[:, j], low, high)
                answers.append(x)
                factorisations += steps
                quick += x is not None and steps <= QUICK_STEPS
                k += 1
        rows[f"primal-dual active set {name} ({quick} settled within {QUICK_STEPS} steps)"] = (
            answers, time.process_time() - t, factorisations)

    return unconstrained_line


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--projects", default="dq-symbols,kraken-symbols")
    ap.add_argument("--corpus", type=Path, default=CORPUS)
    ap.add_argument("--record", type=Path, help="file of recorded calls: read if it exists, else written")
    ap.add_argument("--per-mesh", action="store_true", help="CPU per mesh of PIQP, harmonic and geodesic weights")
    ap.add_argument("--other-solvers", action="store_true", help="PIQP beside Clarabel, OSQP, ProxQP and HiGHS")
    ap.add_argument("--budget", type=float, default=60.0, help="CPU seconds for each other solver (default 60)")
    args = ap.parse_args()
    if args.record and args.record.exists():
        calls = pickle.loads(args.record.read_bytes())
    else:
        calls = record([args.corpus / p for p in args.projects.split(",")])
        if args.record:
            args.record.write_bytes(pickle.dumps(calls))
    if args.per_mesh:
        print(per_mesh(calls))
        return
    problems = qps(calls)
    count = sum(c.shape[1] for _, c in problems)
    print(f"{len(calls)} calls of bounded_biharmonic, {len(problems)} with two bones or more: {count} QPs "
          f"(median {int(np.median([q.shape[0] for q, _ in problems]))} free points)\n")

    rows: dict[str, tuple] = {}

    def piqp(name: str, **settings) -> list:
        import piqp as solver_module

        answers, t, iterations = [], time.process_time(), 0
        real = solver_module.SparseSolver.solve

        def counted(self):
            nonlocal iterations
            status = real(self)
            iterations += self.result.info.iter
            return status

        solver_module.SparseSolver.solve = counted
        try:
            for q, c in problems:
                x = rig_weights.solve_box_qps(q, c, **settings)
                answers += [None] * c.shape[1] if x is None else list(x.T)
        finally:
            solver_module.SparseSolver.solve = real
        rows[name] = (answers, time.process_time() - t, iterations)
        return answers

    piqp(f"PIQP, tolerance {rig_weights.SOLVER_TOLERANCE:g} (shipped)")
    reference = piqp("PIQP, tolerance 1e-10, duality gap 1e-12 (reference)", tolerance=1e-10,
                     eps_duality_gap_abs=1e-12, eps_duality_gap_rel=1e-12)
    if args.other_solvers:
        rows.update(other_solvers(problems, args.budget))
    for rounds in () if args.other_solvers else (3, 2):
        piqp(f"PIQP, {rounds} rounds of equilibration", preconditioner_iter=rounds)
    # with three bones or more each is solved: were their weights a partition, one could be 1 - the others
    k, sums = 0, []
    for _, c in problems:
        if c.shape[1] >= 3:
            sums.append(np.abs(np.sum(reference[k:k + c.shape[1]], axis=0) - 1).max())
        k += c.shape[1]
    partition_line = (f"meshes of three bones or more: {len(sums)}, their reference weights' sums apart from 1 "
                      f"by {min(sums, default=0):.2f} to {max(sums, default=0):.2f} (most per mesh)")

    unconstrained_line = "" if args.other_solvers else exact_methods(problems, rows)

    print("| method | QPs solved | CPU s | per QP ms | factorisations (PIQP: iterations) | max abs diff to reference | 99th pct |")
    print("|---|--:|--:|--:|--:|--:|--:|")
    for name, (answers, cpu, work, *tried) in rows.items():
        diff = [np.abs(x - r).max() for x, r in zip(answers, reference) if x is not None and r is not None]
        solved = sum(x is not None for x in answers)
        per_qp = 1000 * cpu / max(tried[0] if tried else count, 1)  # a budgeted solver: per QP it tried
        print(f"| {name} | {solved} of {count} | {cpu:.2f} | {per_qp:.1f} | {work} | "
              f"{max(diff, default=0):.1e} | {np.quantile(diff, 0.99) if diff else 0:.1e} |")
    print("\n".join(filter(None, ("", unconstrained_line, partition_line))))


if __name__ == "__main__":
    main()
