"""The peer side of drape's CPU comparison: NVIDIA Newton's XPBD and VBD
cloth solvers on Warp's CPU device, on the same hanging cloths as
`hanging-*.toml` beside this file.

The cloth: `columns` x `rows` particles `spacing` metres apart, each of
`mass` kg, lying flat and pinned along one short edge (the row drape calls
row 0), falling under g = 9.8 m/s^2 and swinging down; frames of 1/60 s.
Newton's own cloth example (`example_cloth_hanging.py`) sets the solver
settings used here: 10 substeps a frame, 10 iterations a substep; the
springs (XPBD) and membrane (VBD) as stiff for their mass as there too
(ke = 1e3 for particles of 0.1 kg: ke/m = 1e4 per second squared). Stiffer
XPBD springs stretch more, not less: ke = 1e4 on the 20 x 30 cloth's
0.2 kg particles left 13 % typical strain against 2 % at 1e3, and
ke = 1e3 on the 256 x 256 cloth's 1 g particles blew up; Newton's XPBD
iterates Jacobi-style, and over-shoots when springs are stiff for the mass.

Reports, like `drape run`: wall time per frame (stepping only: positions
are read back for the strain outside the timed part; the first frame,
which compiles Warp's kernels, is left out), and the structural strain
(the horizontal and vertical neighbours, |length/rest - 1|): each frame's
largest, averaged over the frames (typical) and the largest of all (worst).

    python newton_cloth.py --columns 20 --rows 30 --spacing 0.5 --mass 0.2 --frames 120 --solver xpbd
"""

import argparse
import time

import numpy as np
import warp as wp

import newton


def build(args):
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, -9.8))
    params = {
        "pos": wp.vec3(0.0, 0.0, 10.0),
        "rot": wp.quat_identity(),
        "vel": wp.vec3(0.0, 0.0, 0.0),
        # Cells, not particles: dim_x + 1 particles along x.
        "dim_x": args.columns - 1,
        "dim_y": args.rows - 1,
        "cell_x": args.spacing,
        "cell_y": args.spacing,
        "mass": args.mass,
        # The top edge (y = dim_y) is pinned, as drape pins its row 0.
        "fix_top": True,
        "particle_radius": 0.25 * args.spacing,
    }
    if args.solver == "xpbd":
        params.update(add_springs=True, spring_ke=args.stiffness, spring_kd=1.0e-3 * args.stiffness, edge_ke=1.0e2 * args.mass, edge_kd=0.0)
    else:
        params.update(tri_ke=args.stiffness, tri_ka=args.stiffness, tri_kd=1.0e-1 * args.stiffness, edge_ke=1.0e2 * args.mass)
    builder.add_cloth_grid(**params)
    if args.solver == "vbd":
        builder.color(include_bending=True)
    model = builder.finalize()
    if args.solver == "xpbd":
        solver = newton.solvers.SolverXPBD(model=model, iterations=args.iterations)
    else:
        solver = newton.solvers.SolverVBD(model=model, iterations=args.iterations)
    return model, solver


def structural_edges(columns, rows):
    """Index pairs of horizontal and vertical neighbours (row-major ids)."""
    ids = np.arange(columns * rows).reshape(rows, columns)
    horizontal = np.stack([ids[:, :-1].ravel(), ids[:, 1:].ravel()], axis=1)
    vertical = np.stack([ids[:-1, :].ravel(), ids[1:, :].ravel()], axis=1)
    return np.concatenate([horizontal, vertical])


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--columns", type=int, default=20)
    parser.add_argument("--rows", type=int, default=30)
    parser.add_argument("--spacing", type=float, default=0.5)
    parser.add_argument("--mass", type=float, default=0.2)
    parser.add_argument("--frames", type=int, default=120)
    parser.add_argument("--substeps", type=int, default=10)
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument(
        "--stiffness",
        type=float,
        default=None,
        help="spring_ke (XPBD; spring_kd = 1e-3 of it) or tri_ke = tri_ka (VBD; tri_kd = 0.1 of it); "
        "default 1e4 x mass, the ratio of Newton's example (1e3 for 0.1 kg)",
    )
    parser.add_argument("--solver", choices=["xpbd", "vbd"], default="xpbd")
    args = parser.parse_args()
    if args.stiffness is None:
        args.stiffness = 1.0e4 * args.mass

    wp.init()
    with wp.ScopedDevice("cpu"):
        model, solver = build(args)
        state_0, state_1 = model.state(), model.state()
        control = model.control()
        edges = structural_edges(args.columns, args.rows)
        rest = np.linalg.norm(np.diff(state_0.particle_q.numpy()[edges], axis=1)[:, 0], axis=1)
        dt = 1.0 / 60.0 / args.substeps

        states = [state_0, state_1]

        def simulate():
            for s in range(args.substeps):
                a, b = states[s % 2], states[(s + 1) % 2]
                a.clear_forces()
                solver.step(a, b, control, None, dt)

        # One frame recorded as a graph and replayed, as Newton's examples
        # do, so Python's launch overhead is not counted (substeps is even,
        # so the frame ends in state_0 again).
        assert args.substeps % 2 == 0, "an even number of substeps"
        with wp.ScopedCapture() as capture:
            simulate()
        worst_per_frame, seconds = [], []
        for frame in range(args.frames):
            start = time.perf_counter()
            wp.capture_launch(capture.graph)
            wp.synchronize()
            if frame > 0:
                seconds.append(time.perf_counter() - start)
            q = state_0.particle_q.numpy()
            if not np.all(np.isfinite(q)):
                raise SystemExit(f"{args.solver}: non-finite positions at frame {frame}")
            length = np.linalg.norm(q[edges[:, 1]] - q[edges[:, 0]], axis=1)
            worst_per_frame.append(float(np.max(np.abs(length / rest - 1.0))))

    per_frame = sum(seconds) / max(len(seconds), 1)
    print(
        f"newton {newton.__version__} warp {wp.__version__} {args.solver}: "
        f"{args.columns}x{args.rows}, {args.substeps} substeps x {args.iterations} iterations, "
        f"stiffness {args.stiffness:g}: {per_frame * 1e3:.3f} ms per frame, "
        f"structural strain {np.mean(worst_per_frame):.4e} typical, {np.max(worst_per_frame):.4e} worst"
    )


if __name__ == "__main__":
    main()
