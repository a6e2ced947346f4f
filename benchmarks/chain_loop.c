/* Plain velocity-Verlet loop of a magnet chain: the reference speed for bench_engine.py.
 *
 * The same equations as the package's deck, in SI units: N magnets of mass m at x_i = i r0,
 * nearest neighbours repelling with F(r) = K / (r + b)^3 (the paper's law, q = 3); magnet 0 is
 * the impactor, moved at constant velocity V (x_0 = V t, v_0 = V, as `fix move linear`);
 * magnet N-1 is held; the others start at rest and follow velocity Verlet (as `fix nve`).
 *
 *   chain_loop N STEPS DT K B M R0 V VELOCITIES_OUT
 *
 * prints the loop's own wall time and CPU time in seconds (allocation and set-up excluded) and
 * writes the final velocities as N little-endian doubles (m/s) to VELOCITIES_OUT.
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(clockid_t clock)
{
    struct timespec ts;
    clock_gettime(clock, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/* F[i] = F(r_i), r_i = x[i+1] - x[i]; one array per gap, so that gcc vectorises the loop
 * (about 1.2x faster than carrying F(r_(i-1)) from one iteration to the next) */
static void gap_forces(long n, const double *restrict x, double *restrict F, double K, double b)
{
    for (long i = 0; i < n - 1; i++) {
        double s = x[i + 1] - x[i] + b;
        F[i] = K / (s * s * s);
    }
}

int main(int argc, char **argv)
{
    if (argc != 10) {
        fprintf(stderr, "usage: %s N STEPS DT K B M R0 V VELOCITIES_OUT\n", argv[0]);
        return 2;
    }
    long n = atol(argv[1]), steps = atol(argv[2]);
    double dt = atof(argv[3]), K = atof(argv[4]), b = atof(argv[5]), m = atof(argv[6]);
    double r0 = atof(argv[7]), V = atof(argv[8]);
    if (n < 3 || steps < 1) {
        fprintf(stderr, "N must be >= 3 and STEPS >= 1\n");
        return 2;
    }
    double *x = malloc(n * sizeof *x), *v = calloc(n, sizeof *v), *F = malloc(n * sizeof *F);
    if (!x || !v || !F) {
        fprintf(stderr, "out of memory\n");
        return 1;
    }
    for (long i = 0; i < n; i++)
        x[i] = i * r0;
    double x_impactor = x[0];
    v[0] = V;
    gap_forces(n, x, F, K, b);

    /* magnet i (1..n-2) feels F(r_(i-1)) - F(r_i) */
    double half = 0.5 * dt / m;
    double start = now(CLOCK_MONOTONIC), start_cpu = now(CLOCK_PROCESS_CPUTIME_ID);
    for (long step = 1; step <= steps; step++) {
        for (long i = 1; i < n - 1; i++) {
            v[i] += half * (F[i - 1] - F[i]);
            x[i] += dt * v[i];
        }
        x[0] = x_impactor + V * (step * dt);
        gap_forces(n, x, F, K, b);
        for (long i = 1; i < n - 1; i++)
            v[i] += half * (F[i - 1] - F[i]);
    }
    double seconds = now(CLOCK_MONOTONIC) - start, cpu = now(CLOCK_PROCESS_CPUTIME_ID) - start_cpu;

    FILE *out = fopen(argv[9], "wb");
    if (!out || fwrite(v, sizeof *v, n, out) != (size_t)n || fclose(out) != 0) {
        fprintf(stderr, "cannot write %s\n", argv[9]);
        return 1;
    }
    printf("%.9g %.9g\n", seconds, cpu);
    free(x);
    free(v);
    free(F);
    return 0;
}
