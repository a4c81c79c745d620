#!/usr/bin/env python3
"""Reflected radiance of a plane-parallel slab by the adding-doubling method.

An independent reference for `haze validate`'s dense case (src/lab/validate.rs, "dense slab"):
a slab of optical thickness tau and single-scattering albedo omega, isotropic scattering, no
refractive boundary, black below, lit by collimated light of irradiance 1 at normal incidence;
the radiance reflected straight up (mu = 1) per unit irradiance.

Method (van de Hulst 1980, "Multiple Light Scattering", ch. 5; Wiscombe 1976, "On initialization,
error and flux conservation in the doubling method", JQSRT 16; Prahl 1995, "The adding-doubling
method", in Optical-Thermal Response of Laser-Irradiated Tissue): discrete ordinates on a
Gauss-Radau rule over mu in (0, 1] whose fixed node is mu = 1, so that the collimated beam is one
of the ordinates; a thin layer of thickness tau / 2^k from the diamond-difference
initialisation; k doublings R' = R + T (I - R R)^-1 R T, T' = T (I - R R)^-1 T. The operators act
on radiance at the nodes (the quadrature weights are inside them), so the collimated beam of
irradiance E enters as the radiance E / (2 pi w_0 mu_0) on the node mu_0 = 1.

Pure Python (no NumPy), so that it runs wherever python3 does. It checks itself against the
semi-infinite limit, Chandrasekhar's H-function (omega H(1)^2 / (8 pi) at mu = mu_0 = 1), and
prints the answer at several orders so that its convergence can be read off:

    python3 tests/adding_doubling.py            # the dense case: tau 20, omega 0.999
    python3 tests/adding_doubling.py 20 0.999 --check

With --source it prints instead the source function S(tau) = omega J(tau) of the semi-infinite
medium (a slab of depth 60) under the same light, per unit irradiance, at the depths of the table
`HALF_SPACE_SOURCE` of src/lab/validate.rs (the all-orders half-space cases' kernel expectations):
the mean intensity J at depth tau from the radiances at the interface of a top layer of thickness
tau over the rest, by adding (D = (I - R_a R_b)^-1 T_a I_0 going down, U = R_b D going up):

    python3 tests/adding_doubling.py --source 0.8
"""

import math
import sys


def legendre(n, x):
    """P_n(x) and P_{n-1}(x) by the three-term recurrence."""
    p0, p1 = 1.0, x
    if n == 0:
        return 1.0, 0.0
    for k in range(2, n + 1):
        p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
    return p1, p0


def radau(n):
    """Gauss-Radau nodes and weights on [0, 1] with the fixed node 1 (n nodes in all).

    On [-1, 1] with the fixed node +1, the free nodes are the roots of P_{n-1}(x) - P_n(x)
    other than 1, and the weights are (1 + x_i) / (n^2 P_{n-1}(x_i)^2) and 2 / n^2 at 1.
    """
    f = lambda x: legendre(n, x)[1] - legendre(n, x)[0]
    # Bracket the roots on a fine grid (they are simple and lie in (-1, 1)).
    grid = [-1.0 + 2.0 * i / (200 * n) for i in range(200 * n + 1)]
    roots = []
    for a, b in zip(grid, grid[1:]):
        fa, fb = f(a), f(b)
        if b >= 1.0 - 1e-12:
            break
        if fa == 0.0:
            roots.append(a)
        elif fa * fb < 0.0:
            for _ in range(200):
                m = 0.5 * (a + b)
                fm = f(m)
                if fa * fm <= 0.0:
                    b, fb = m, fm
                else:
                    a, fa = m, fm
            roots.append(0.5 * (a + b))
    assert len(roots) == n - 1, (n, len(roots))
    nodes = [(x + 1.0) / 2.0 for x in roots] + [1.0]
    weights = [(1.0 + x) / (n * n * legendre(n, x)[1] ** 2) / 2.0 for x in roots] + [1.0 / (n * n)]
    return nodes, weights


def solve(a, b):
    """Solves A X = B (A n x n, B n x m) by Gaussian elimination with partial pivoting."""
    n, m = len(a), len(b[0])
    aug = [list(a[i]) + list(b[i]) for i in range(n)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(aug[r][c]))
        aug[c], aug[p] = aug[p], aug[c]
        piv = aug[c][c]
        row = [v / piv for v in aug[c]]
        aug[c] = row
        for r in range(n):
            if r != c and aug[r][c] != 0.0:
                k = aug[r][c]
                aug[r] = [x - k * y for x, y in zip(aug[r], row)]
    return [aug[i][n:] for i in range(n)]


def matmul(a, b):
    bt = list(zip(*b))
    return [[sum(x * y for x, y in zip(row, col)) for col in bt] for row in a]


def eye(n):
    return [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]


def sub(a, b):
    return [[x - y for x, y in zip(ra, rb)] for ra, rb in zip(a, b)]


def add(a, b):
    return [[x + y for x, y in zip(ra, rb)] for ra, rb in zip(a, b)]


def thin_layer(mu, w, omega, delta):
    """R and T of a layer of optical thickness delta by the diamond-difference scheme.

    Discrete ordinates: mu_i dI+_i/dtau = -I+_i + (omega/2) sum_j w_j (I+_j + I-_j), and the same
    for I- travelling up. With a = (delta/2) M^-1 (I - C), b = (delta/2) M^-1 C (M = diag(mu),
    C_ij = omega w_j / 2), light x from above and none from below: (I + a) T - b R = I - a and
    (I + a) R - b T = b.
    """
    n = len(mu)
    c = [[omega * w[j] / 2.0 for j in range(n)] for _ in range(n)]
    a = [[(delta / 2.0) * ((1.0 if i == j else 0.0) - c[i][j]) / mu[i] for j in range(n)] for i in range(n)]
    b = [[(delta / 2.0) * c[i][j] / mu[i] for j in range(n)] for i in range(n)]
    ia = add(eye(n), a)
    big = [ia[i] + [-x for x in b[i]] for i in range(n)] + [[-x for x in b[i]] + ia[i] for i in range(n)]
    rhs = [sub(eye(n), a)[i] for i in range(n)] + [b[i] for i in range(n)]
    sol = solve(big, rhs)
    return sol[n:], sol[:n]  # R, T


def slab(tau, omega, n, doublings=24):
    """R and T operators of the slab, and the nodes and weights."""
    mu, w = radau(n)
    r, t = thin_layer(mu, w, omega, tau / 2.0 ** doublings)
    for _ in range(doublings):
        rr = sub(eye(n), matmul(r, r))
        inv_t = solve(rr, t)  # (I - R R)^-1 T
        r = add(r, matmul(matmul(t, r), inv_t))
        t = matmul(t, inv_t)
    return r, t, mu, w


def reflected_normal(tau, omega, n):
    """Radiance reflected at mu = 1 per unit irradiance at normal incidence."""
    r, _, mu, w = slab(tau, omega, n)
    beam = 1.0 / (2.0 * math.pi * w[-1] * mu[-1])
    return r[-1][-1] * beam


def h_function(omega, mu, n=400):
    """Chandrasekhar's H(mu) for isotropic scattering by iterating 1/H = sqrt(1-omega) + (omega/2)
    int_0^1 mu' H(mu') / (mu + mu') dmu' on a Gauss-Legendre rule (as an independent check)."""
    xs, ws = [], []
    # Gauss-Legendre on [0, 1] by Newton on P_n.
    for i in range(1, n + 1):
        x = math.cos(math.pi * (i - 0.25) / (n + 0.5))
        for _ in range(100):
            p, q = legendre(n, x)
            dp = n * (x * p - q) / (x * x - 1.0)
            dx = p / dp
            x -= dx
            if abs(dx) < 1e-15:
                break
        p, q = legendre(n, x)
        dp = n * (x * p - q) / (x * x - 1.0)
        xs.append((x + 1.0) / 2.0)
        ws.append(1.0 / ((1.0 - x * x) * dp * dp))
    h = [1.0] * n
    for _ in range(2000):
        new = [
            1.0 / (math.sqrt(1.0 - omega) + omega / 2.0 * sum(wj * xj * hj / (xi + xj) for wj, xj, hj in zip(ws, xs, h)))
            for xi in xs
        ]
        done = max(abs(a - b) for a, b in zip(new, h)) < 1e-14
        h = new
        if done:
            break
    return 1.0 / (math.sqrt(1.0 - omega) + omega / 2.0 * sum(wj * xj * hj / (mu + xj) for wj, xj, hj in zip(ws, xs, h)))


SOURCE_DEPTHS = (
    [0.002 * k for k in range(51)]
    + [0.1 + 0.02 * k for k in range(1, 46)]
    + [1.0 + 0.25 * k for k in range(1, 61)]
)


def source_profile(omega, depths, n, deep=60.0):
    """S(tau) per unit irradiance at normal incidence, at each depth, in a semi-infinite medium."""
    rb, _, mu, w = slab(deep, omega, n)
    i0 = [[0.0] for _ in range(n)]
    i0[-1][0] = 1.0 / (2.0 * math.pi * w[-1] * mu[-1])
    out = []
    for tau in depths:
        if tau == 0.0:
            d = i0
        else:
            ra, ta, _, _ = slab(tau, omega, n)
            d = solve(sub(eye(n), matmul(ra, rb)), matmul(ta, i0))
        u = matmul(rb, d)
        four_pi_j = 2.0 * math.pi * sum(w[i] * (d[i][0] + u[i][0]) for i in range(n))
        out.append(omega * four_pi_j / (4.0 * math.pi))
    return out


def main():
    if "--source" in sys.argv:
        omega = float(sys.argv[sys.argv.index("--source") + 1])
        coarse = source_profile(omega, SOURCE_DEPTHS, 8)
        fine = source_profile(omega, SOURCE_DEPTHS, 16)
        print(f"// S(tau) per unit irradiance, omega {omega}, 16 Radau nodes (8 nodes differ by at most "
              f"{max(abs(a / b - 1.0) for a, b in zip(coarse, fine)):.1e} relative)")
        for k in range(0, len(fine), 6):
            print("    " + " ".join(f"{v:.9e}," for v in fine[k:k + 6]))
        return
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    tau = float(args[0]) if args else 20.0
    omega = float(args[1]) if len(args) > 1 else 0.999
    if "--check" in sys.argv:
        # The rule integrates polynomials of degree 2n - 2 exactly.
        mu, w = radau(12)
        for k in range(23):
            exact = 1.0 / (k + 1)
            got = sum(wi * m ** k for wi, m in zip(w, mu))
            assert abs(got - exact) < 1e-12, (k, got, exact)
        # Single scattering (omega -> 0): omega (1 - e^{-2 tau}) / (8 pi).
        for t in (0.5, 2.0):
            ss = 1e-6 * (1.0 - math.exp(-2.0 * t)) / (8.0 * math.pi)
            got = reflected_normal(t, 1e-6, 16)
            assert abs(got / ss - 1.0) < 1e-5, (t, got, ss)
        # The semi-infinite limit: omega H(1)^2 / (8 pi).
        for om in (0.8, 0.99):
            h1 = h_function(om, 1.0)
            half = om * h1 * h1 / (8.0 * math.pi)
            got = reflected_normal(4096.0, om, 24)
            print(f"half-space omega {om}: doubling {got:.8f}, H-function {half:.8f}, ratio {got / half:.7f}")
            assert abs(got / half - 1.0) < 2e-5, (om, got, half)
    for n in (8, 16, 24, 32):
        print(f"tau {tau}, omega {omega}, {n} Radau nodes: L_r(1) / E = {reflected_normal(tau, omega, n):.9f}")


if __name__ == "__main__":
    main()
