"""Peer benchmark: N×N cable nets solved by tdeploy, compas_dr and MusclePy.

The nets (issue 12): N×N nodes on a 1 m grid in the plane z = 0, the
perimeter pinned, tension-only cables between grid neighbours with
EA = 1256.636 kN and rest length 0.998 × initial length, −1 kN (z) on every
free node. Every solver starts from the flat grid.

Each answer is checked against a reference solved here by Newton's method
on the exact (tension-only) equations to a residual below 1e-8 N, itself
checked against the independent 7×7 reference of the repository
(tests/data/cable-net-7x7.json, 1e-7 m). An answer more than 1e-6 m from
the reference (largest node distance) fails the run.

Every solver stops on a force tolerance of 1e-3 N (tdeploy: largest
out-of-balance force on a node; MusclePy: on each DOF; compas_dr: on the
2-norm of all residuals, the strictest of the three). Times are the
fastest of repeated solves in this one process (at least one, more while
they fit in REPEAT_S seconds), measured inside each solver's process:
start-up, file and import costs excluded. Run through run.sh.
"""

import argparse
import json
import math
import subprocess
import sys
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

EA_N = 1256636.0
REST_FACTOR = 0.998
LOAD_N = -1000.0
TOL_N = 1e-3
ACCURACY_M = 1e-6
REPEAT_S = 2.0


def make_net(n):
    """The N×N net: positions (n², 3), members (m, 2), fixed (bool n²), loads."""
    x = np.array([[i, j, 0.0] for j in range(n) for i in range(n)], dtype=float)
    fixed = np.array([i in (0, n - 1) or j in (0, n - 1) for j in range(n) for i in range(n)])
    members = []
    for j in range(n):
        for i in range(n):
            k = j * n + i
            if i + 1 < n:
                members.append((k, k + 1))
            if j + 1 < n:
                members.append((k, k + n))
    members = np.array(members, dtype=int)
    length = np.linalg.norm(x[members[:, 1]] - x[members[:, 0]], axis=1)
    loads = np.zeros_like(x)
    loads[~fixed, 2] = LOAD_N
    return {
        "n": n,
        "positions_m": x,
        "members": members,
        "fixed": fixed,
        "rest_length_m": REST_FACTOR * length,
        "loads_n": loads,
    }


def internal_forces(net, x):
    """Member tensions (tension-only) and the net internal force on each node."""
    a, b = net["members"][:, 0], net["members"][:, 1]
    d = x[b] - x[a]
    length = np.linalg.norm(d, axis=1)
    rest = net["rest_length_m"]
    t = np.maximum(EA_N * (length - rest) / rest, 0.0)
    f = (t / length)[:, None] * d
    out = np.zeros_like(x)
    np.add.at(out, a, f)
    np.add.at(out, b, -f)
    return t, out


def residual(net, x):
    """Out-of-balance force on every node (zero rows at pinned nodes)."""
    _, f = internal_forces(net, x)
    r = net["loads_n"] + f
    r[net["fixed"]] = 0.0
    return r


def reference_solve(net):
    """Newton with the exact tangent and a backtracking line search."""
    x = net["positions_m"].copy()
    free = np.flatnonzero(~net["fixed"])
    dof = -np.ones((len(x), 3), dtype=int)
    dof[free] = np.arange(3 * len(free)).reshape(-1, 3)
    a, b = net["members"][:, 0], net["members"][:, 1]
    rest = net["rest_length_m"]
    for _ in range(200):
        r = residual(net, x)
        if np.abs(r).max() < 1e-8:
            break
        d = x[b] - x[a]
        length = np.linalg.norm(d, axis=1)
        e = d / length[:, None]
        slack = length <= rest
        t = np.where(slack, 0.0, EA_N * (length - rest) / rest)
        k_axial = np.where(slack, 0.0, EA_N / rest)
        ke = k_axial[:, None, None] * np.einsum("mi,mj->mij", e, e) + (t / length)[
            :, None, None
        ] * (np.eye(3)[None] - np.einsum("mi,mj->mij", e, e))
        rows, cols, vals = [], [], []
        for (p, q, s) in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
            for i in range(3):
                for j in range(3):
                    rr, cc = dof[p, i], dof[q, j]
                    ok = (rr >= 0) & (cc >= 0)
                    rows.append(rr[ok])
                    cols.append(cc[ok])
                    vals.append(s * ke[ok, i, j])
        k = sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(3 * len(free), 3 * len(free)),
        )
        dx = spla.spsolve(k, r[free].ravel()).reshape(-1, 3)
        norm0 = np.linalg.norm(r)
        alpha = 1.0
        for _ in range(30):
            trial = x.copy()
            trial[free] += alpha * dx
            if np.linalg.norm(residual(net, trial)) < norm0 or alpha < 1e-6:
                break
            alpha *= 0.5
        x = trial
    else:
        raise RuntimeError(f"reference Newton did not converge for N = {net['n']}")
    t, _ = internal_forces(net, x)
    if t.min() <= 0.0:
        raise RuntimeError("reference has a slack cable: the nets are meant to be all in tension")
    return x


def timed(solve, budget_s=REPEAT_S):
    """(fastest time, last result) over repeated solves within budget_s."""
    best, spent, result = math.inf, 0.0, None
    while True:
        start = time.perf_counter()
        result = solve()
        elapsed = time.perf_counter() - start
        best, spent = min(best, elapsed), spent + elapsed
        if spent + best > budget_s:
            return best, result


def compas_solve(net):
    """compas_dr's dr_numpy (loads in kN, E in kN/mm², radius in mm)."""
    from compas_dr.numdata import InputData
    from compas_dr.solvers import dr_numpy

    m = len(net["members"])
    radius = 1.0
    # compas_dr takes A = 3.14159·r² (not π): E makes E·A exactly EA.
    e_kn_per_mm2 = EA_N / 1000.0 / (3.14159 * radius**2)
    indata = InputData(
        vertices=net["positions_m"].tolist(),
        edges=[tuple(int(v) for v in e) for e in net["members"]],
        fixed=[int(i) for i in np.flatnonzero(net["fixed"])],
        loads=(net["loads_n"] / 1000.0).tolist(),
        qpre=[0.0] * m,
        fpre=[0.0] * m,
        lpre=[0.0] * m,
        linit=net["rest_length_m"].tolist(),
        E=[e_kn_per_mm2] * m,
        radius=[radius] * m,
    )
    iterations = []
    result = dr_numpy(
        indata,
        kmax=2_000_000,
        tol1=TOL_N / 1000.0,
        tol2=0.0,
        callback=lambda k, *_: iterations.append(k),
    )
    return np.asarray(result.xyz), len(iterations)


def muscle_solve(net, max_steps):
    """MusclePy's main_dynamic_relaxation (area mm², Young's moduli MPa,
    zero in compression: tension-only)."""
    from musclepy import PyConfigDR, PyElements, PyNodes, PyTruss, main_dynamic_relaxation

    m = len(net["members"])
    nodes = PyNodes(
        initial_coordinates=net["positions_m"],
        dof=np.repeat(~net["fixed"][:, None], 3, axis=1),
    )
    area_mm2 = EA_N / 1000.0  # with E = 1000 MPa: EA in N
    elements = PyElements(
        nodes,
        type=np.ones(m, dtype=int),
        end_nodes=net["members"],
        area=np.full(m, area_mm2),
        youngs=np.tile([0.0, 1000.0], (m, 1)),
        free_length=net["rest_length_m"],
    )
    config = PyConfigDR(
        max_time_step=max_steps,
        max_ke_reset=10**9,
        zero_residual_rtol=1e-300,
        zero_residual_atol=TOL_N,
    )
    out = main_dynamic_relaxation(PyTruss(nodes, elements), loads_increment=net["loads_n"], config=config)
    x = out.nodes.coordinates
    converged = out.is_in_equilibrium(rtol=1e-300, atol=TOL_N)
    return np.asarray(x), config.n_time_step, converged


def check(name, n, x, reference):
    err = float(np.linalg.norm(np.asarray(x) - reference, axis=1).max())
    if not err <= ACCURACY_M:
        sys.exit(f"FAILED: {name}, N = {n}: {err:.2e} m from the reference (allowed {ACCURACY_M:.0e} m)")
    return err


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", default="5,7,11,15,21,31")
    p.add_argument("--tdeploy-example", required=True, help="path of the built peer_nets example")
    p.add_argument("--net-file", required=True, help="where to write the nets for tdeploy")
    p.add_argument("--repo-reference", required=True, help="tests/data/cable-net-7x7.json")
    p.add_argument(
        "--muscle-budget-s",
        type=float,
        default=120.0,
        help="longest MusclePy solve attempted, s (it assembles dense 3n×3n stiffness matrices every step)",
    )
    args = p.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]

    # The reference solver against the repository's independent 7×7 answer.
    with open(args.repo_reference) as f:
        repo = json.load(f)
    net7 = make_net(7)
    assert np.allclose(net7["positions_m"], repo["nodes_initial_m"])
    ref7 = reference_solve(net7)
    gap = np.linalg.norm(ref7 - np.array(repo["nodes_equilibrium_m"]), axis=1).max()
    if not gap <= 1e-7:
        sys.exit(f"FAILED: the reference Newton is {gap:.2e} m from the repository's 7×7 answer")
    print(f"reference Newton vs the repository's 7×7 reference: {gap:.1e} m")

    nets = {n: make_net(n) for n in sizes}
    refs = {n: reference_solve(nets[n]) for n in sizes}
    with open(args.net_file, "w") as f:
        json.dump(
            [
                {
                    "n": n,
                    "positions_m": net["positions_m"].tolist(),
                    "members": net["members"].tolist(),
                    "fixed": net["fixed"].tolist(),
                    "rest_length_m": net["rest_length_m"].tolist(),
                    "loads_n": net["loads_n"].tolist(),
                    "ea_n": EA_N,
                    "tol_n": TOL_N,
                    "repeat_s": REPEAT_S,
                }
                for n, net in nets.items()
            ],
            f,
        )
    ours = json.loads(subprocess.run([args.tdeploy_example, args.net_file], check=True, capture_output=True, text=True).stdout)

    rows = []
    for entry in ours:
        n = entry["n"]
        net, ref = nets[n], refs[n]
        row = {"n": n}
        for mode in ("default", "dr"):
            r = entry[mode]
            if r["status"] != "Converged":
                sys.exit(f"FAILED: tdeploy {mode}, N = {n}: {r['status']}")
            row[mode] = (r["seconds"], check(f"tdeploy {mode}", n, np.array(r["positions_m"]), ref), r["iterations"])
        t, (x, its) = timed(lambda: compas_solve(net))
        row["compas"] = (t, check("compas_dr", n, x, ref), its)
        # MusclePy: time a few steps first and only attempt what fits the budget.
        t0 = time.perf_counter()
        muscle_solve(net, 3)
        per_step = (time.perf_counter() - t0) / 3
        max_steps = max(int(args.muscle_budget_s / per_step), 4)
        t0 = time.perf_counter()
        x, steps, converged = muscle_solve(net, max_steps)
        elapsed = time.perf_counter() - t0
        if converged:
            if elapsed * 2 < REPEAT_S:
                elapsed, (x, steps, converged) = timed(lambda: muscle_solve(net, max_steps))
            row["muscle"] = (elapsed, check("MusclePy", n, x, ref), steps)
        else:
            row["muscle"] = (None, elapsed, steps)
        rows.append(row)
        print_row(row)
    print(
        "\nratios > 1: tdeploy faster. Times: fastest of repeated solves in one process; "
        "iterations: Newton + DR for tdeploy's default, DR steps otherwise."
    )


HEADER_PRINTED = []


def print_row(row):
    if not HEADER_PRINTED:
        print(
            f"{'N':>3} {'DOFs':>5} | {'tdeploy default':>22} | {'tdeploy pure DR':>18} | {'compas_dr':>18} | {'MusclePy':>20} | "
            f"{'compas/default':>14} {'compas/DR':>9} {'Muscle/default':>14} {'default/DR':>10}"
        )
        HEADER_PRINTED.append(True)
    n = row["n"]
    d, r, c, m = row["default"], row["dr"], row["compas"], row["muscle"]

    def fmt(t):
        return f"{t * 1e3:9.3f} ms" if t < 10 else f"{t:9.2f} s "

    d_its = f"{d[2][0]}+{d[2][1]}"
    muscle = f"{fmt(m[0])} {m[2]:>7}" if m[0] is not None else f"> {m[1]:5.0f} s ({m[2]} st.)"
    muscle_ratio = f"{m[0] / d[0]:14.0f}" if m[0] is not None else f"{'> ' + format(m[1] / d[0], '.0f'):>14}"
    print(
        f"{n:>3} {3 * (n - 2) ** 2:>5} | {fmt(d[0])} {d_its:>9} | {fmt(r[0])} {r[2][1]:>5} | {fmt(c[0])} {c[2]:>5} | {muscle:>20} | "
        f"{c[0] / d[0]:14.0f} {c[0] / r[0]:9.0f} {muscle_ratio} {d[0] / r[0]:10.2f}",
        flush=True,
    )


if __name__ == "__main__":
    main()
