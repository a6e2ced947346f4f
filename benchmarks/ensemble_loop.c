/* An ensemble of magnet chains integrated by a plain loop: the reference for bench_sweep.py.
 *
 * The equations and operations of fix lattice/chain (SI units): M chains of N magnets, nearest
 * neighbours repelling with F(r) = K / (r + b)^q; magnet 0 of each chain is the impactor, moved
 * by a half-sine velocity pulse v = V sin(pi t / T) for t < T (x = x0 + V T / pi (1 - cos(pi t / T)),
 * then at rest); magnet N-1 is held; the others follow velocity Verlet with, if mu > 0, the exact
 * Coulomb stick-slip kick of pylmp_lattice/plugin/kernel/coulomb.h (limit mu (m g + p (F_left + F_right))).
 * Each chain starts from its own positions, velocities and masses (read from a file), so the loop
 * does the same integrations as the sweep's members, without their front measures or output.
 *
 *   ensemble_loop M N STEPS DT K B Q V T MU P G STATE_IN VELOCITIES_OUT
 *
 * STATE_IN: M*N doubles x (m), then M*N v (m/s), then M*N masses (kg), little-endian.
 * Prints the loop's wall time in seconds (reading excluded); writes the final velocities
 * (M*N doubles) to VELOCITIES_OUT.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double law(double r, double K, double b, double q)
{
    double s = r + b;
    return q == 3.0 ? K / (s * s * s) : K / pow(s, q);
}

/* kernel/coulomb.h: the constant total force over a kick that reproduces the exact Coulomb solution */
static double coulomb_kick(double v0, double fx, double limit, double dvdf, int *stuck)
{
    *stuck = 0;
    if (v0 == 0.0) {
        if (fabs(fx) <= limit) *stuck = 1;
        return *stuck ? 0.0 : fx - copysign(limit, fx);
    }
    double s = copysign(1.0, v0);
    double ftot = fx - s * limit;
    double v1 = v0 + dvdf * ftot;
    if (s * v1 <= 0.0) {
        if (fabs(fx) <= limit) {
            *stuck = 1;
            return 0.0;
        }
        ftot = (v1 * (fx + s * limit) / ftot - v0) / dvdf;
    }
    return ftot;
}

/* forces of the free magnets with a kick of length `kick` (friction), and `half` of it applied */
static void forces(long n, const double *x, double *v, double *f, double *F, const double *m, double kick,
                   double half, double K, double b, double q, double mu, double p, double g)
{
    for (long i = 0; i < n - 1; i++)
        F[i] = law(x[i + 1] - x[i], K, b, q);
    for (long i = 1; i < n - 1; i++) {
        double fx = F[i - 1] - F[i], ftot = fx;
        if (mu > 0.0) {
            double normal = m[i] * g + p * (F[i - 1] + F[i]);
            int stuck;
            ftot = coulomb_kick(v[i], fx, normal > 0.0 ? mu * normal : 0.0, kick / m[i], &stuck);
            if (stuck) v[i] = 0.0;
        }
        f[i] = ftot;
        v[i] += half / m[i] * ftot;
    }
}

int main(int argc, char **argv)
{
    if (argc != 15) {
        fprintf(stderr, "usage: %s M N STEPS DT K B Q V T MU P G STATE_IN VELOCITIES_OUT\n", argv[0]);
        return 2;
    }
    long chains = atol(argv[1]), n = atol(argv[2]), steps = atol(argv[3]);
    double dt = atof(argv[4]), K = atof(argv[5]), b = atof(argv[6]), q = atof(argv[7]);
    double V = atof(argv[8]), T = atof(argv[9]), mu = atof(argv[10]), p = atof(argv[11]), g = atof(argv[12]);
    long total = chains * n;
    double *x = malloc(total * sizeof *x), *v = malloc(total * sizeof *v), *m = malloc(total * sizeof *m);
    double *f = calloc(n, sizeof *f), *F = malloc(n * sizeof *F);
    FILE *in = fopen(argv[13], "rb");
    if (!x || !v || !m || !f || !F || !in || fread(x, sizeof *x, total, in) != (size_t)total ||
        fread(v, sizeof *v, total, in) != (size_t)total || fread(m, sizeof *m, total, in) != (size_t)total) {
        fprintf(stderr, "cannot read %s\n", argv[13]);
        return 1;
    }
    fclose(in);
    double start = now();
    for (long c = 0; c < chains; c++) {
        double *xc = x + c * n, *vc = v + c * n, *mc = m + c * n, x0 = xc[0];
        vc[0] = 0.0;
        forces(n, xc, vc, f, F, mc, 0.5 * dt, 0.0, K, b, q, mu, p, g);
        for (long s = 1; s <= steps; s++) {
            for (long i = 1; i < n - 1; i++) {
                vc[i] += 0.5 * dt / mc[i] * f[i];
                xc[i] += dt * vc[i];
            }
            double t = s * dt;
            xc[0] = x0 + (t < T ? V * T / M_PI * (1.0 - cos(M_PI * t / T)) : 2.0 * V * T / M_PI);
            vc[0] = t < T ? V * sin(M_PI * t / T) : 0.0;
            forces(n, xc, vc, f, F, mc, dt, 0.5 * dt, K, b, q, mu, p, g);
        }
    }
    printf("%.6f\n", now() - start);
    FILE *out = fopen(argv[14], "wb");
    if (!out || fwrite(v, sizeof *v, total, out) != (size_t)total) {
        fprintf(stderr, "cannot write %s\n", argv[14]);
        return 1;
    }
    fclose(out);
    return 0;
}
