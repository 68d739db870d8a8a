/* The components' physics (crank_components.h). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "crank_components.h"
#include "crank_numbers.h"

/* pi as Python's math.pi (C99 names no PI) */
static const double PI = 3.141592653589793;

double cc_drive_voltage(const double* d, double x, double omega, double omega_set)
{
    return d[CC_KP] * (omega_set - omega) + d[CC_KI] * x;
}

double cc_drive_torque(const double* d, double i) { return d[CC_N_GEAR] * d[CC_K_T] * i; }

/* With the inputs lines in time (omega = omega0 + r t, omega_set = omega_set0 + r_set t; held
 * where the rates are 0), the speed error is e0 + de t, x grows as x0 + e0 t + de t^2/2 and
 * L di/dt = L (p + q t + c2 t^2) - R i: the current relaxes with the time constant L/R towards a
 * polynomial of time, solved in closed form (expm1 keeps 1 - exp(-a h) exact for small steps). */
void cc_drive_step_ramp(const double* d, double i, double x, double omega, double omega_set, double rate,
                        double rate_set, double h, double* out)
{
    double e = omega_set - omega, de = rate_set - rate;
    double a = d[CC_R] / d[CC_L];
    double p = (d[CC_KP] * e + d[CC_KI] * x - d[CC_K_T] * d[CC_N_GEAR] * omega) / d[CC_L];   /* A/s */
    double q = (d[CC_KI] * e + d[CC_KP] * de - d[CC_K_T] * d[CC_N_GEAR] * rate) / d[CC_L];   /* A/s2 */
    double c2 = 0.5 * d[CC_KI] * de / d[CC_L];                                               /* A/s3 */
    double one_minus = -expm1(-a * h);
    out[0] = i * (1.0 - one_minus) + p * one_minus / a + q * (h / a - one_minus / (a * a));
    if (c2 != 0.0) out[0] += c2 * (h * h / a - 2.0 * h / (a * a) + 2.0 * one_minus / (a * a * a));
    out[1] = x + e * h + 0.5 * de * h * h;
}

void cc_drive_step(const double* d, double i, double x, double omega, double omega_set, double h, double* out)
{
    cc_drive_step_ramp(d, i, x, omega, omega_set, 0.0, 0.0, h, out);
}

void cc_drive_rates(const double* d, double i, double x, double omega, double omega_set, double tau_load,
                    double J_drive, int rotor, double* out)
{
    double nk = d[CC_N_GEAR] * d[CC_K_T];
    out[0] = (cc_drive_voltage(d, x, omega, omega_set) - d[CC_R] * i - nk * omega) / d[CC_L];
    out[1] = omega_set - omega;
    if (rotor) out[2] = (nk * i - tau_load) / J_drive;
}

static void matmul(int n, const double* A, const double* B, double* C)
{
    double t[CC_EXPM_MAX * CC_EXPM_MAX];
    for (int r = 0; r < n; r++)
        for (int c = 0; c < n; c++) {
            double s = 0.0;
            for (int k = 0; k < n; k++) s += A[r * n + k] * B[k * n + c];
            t[r * n + c] = s;
        }
    memcpy(C, t, sizeof(double) * (size_t)(n * n));
}

/* M / 2^s has a norm of at most 1/2, where 20 terms of the series reach rounding; then s squarings
 * (numerics.expm states the same method, its reference) */
void cc_expm(int n, const double* M, double* out)
{
    double norm = 0.0;
    for (int r = 0; r < n; r++) {
        double row = 0.0;
        for (int c = 0; c < n; c++) row += fabs(M[r * n + c]);
        if (row > norm) norm = row;
    }
    int s = 0;
    if (norm > 0.0 && isfinite(norm)) {
        s = (int)ceil(log2(norm)) + 1;
        if (s < 0) s = 0;
        if (s > 1000) s = 1000;
    }
    double X[CC_EXPM_MAX * CC_EXPM_MAX], term[CC_EXPM_MAX * CC_EXPM_MAX], sum[CC_EXPM_MAX * CC_EXPM_MAX];
    double scale = ldexp(1.0, -s);
    for (int k = 0; k < n * n; k++) {
        X[k] = M[k] * scale;
        term[k] = (k % (n + 1) == 0) ? 1.0 : 0.0;
        sum[k] = term[k];
    }
    for (int j = 1; j <= 20; j++) {
        matmul(n, term, X, term);
        for (int k = 0; k < n * n; k++) {
            term[k] /= j;
            sum[k] += term[k];
        }
    }
    for (int j = 0; j < s; j++) matmul(n, sum, sum, sum);
    memcpy(out, sum, sizeof(double) * (size_t)(n * n));
}

void cc_expm4(const double* M, double* out) { cc_expm(4, M, out); }

void cc_drive_step_with_rotor(const double* d, double i, double x, double omega, double omega_set, double tau_load,
                              double J_drive, double h, double* out)
{
    cc_drive_step_with_rotor_ramp(d, i, x, omega, omega_set, tau_load, 0.0, 0.0, J_drive, h, out);
}

/* the augmented linear system (i, x, omega, 1) and, where an input is a line, its time t: the
 * inputs' constant parts in the column of 1, their rates in the column of t */
void cc_drive_step_with_rotor_ramp(const double* d, double i, double x, double omega, double omega_set,
                                   double tau_load, double rate_set, double rate_load, double J_drive, double h,
                                   double* out)
{
    double nk = d[CC_N_GEAR] * d[CC_K_T], L = d[CC_L];
    double z[5] = {i, x, omega, 1.0, 0.0};
    if (rate_set == 0.0 && rate_load == 0.0) {
        double A[16] = {-d[CC_R] / L * h, d[CC_KI] / L * h, -(d[CC_KP] + nk) / L * h, d[CC_KP] * omega_set / L * h,
                        0.0, 0.0, -h, omega_set * h,
                        nk / J_drive * h, 0.0, 0.0, -tau_load / J_drive * h,
                        0.0, 0.0, 0.0, 0.0};
        double E[16];
        cc_expm(4, A, E);
        for (int r = 0; r < 3; r++) out[r] = E[r * 4] * z[0] + E[r * 4 + 1] * z[1] + E[r * 4 + 2] * z[2] + E[r * 4 + 3];
        return;
    }
    double A[25] = {-d[CC_R] / L * h, d[CC_KI] / L * h, -(d[CC_KP] + nk) / L * h, d[CC_KP] * omega_set / L * h,
                    d[CC_KP] * rate_set / L * h,
                    0.0, 0.0, -h, omega_set * h, rate_set * h,
                    nk / J_drive * h, 0.0, 0.0, -tau_load / J_drive * h, -rate_load / J_drive * h,
                    0.0, 0.0, 0.0, 0.0, 0.0,
                    0.0, 0.0, 0.0, h, 0.0};
    double E[25];
    cc_expm(5, A, E);
    for (int r = 0; r < 3; r++) {
        out[r] = 0.0;
        for (int k = 0; k < 5; k++) out[r] += E[r * 5 + k] * z[k];
    }
}

double cc_cushion_force(double k, double c, double L_free, double s_seat, double s, double v)
{
    return -(k * ((s - s_seat) - L_free) + c * v);
}

double cc_shaft_torque(double k, double c, double twist, double omega_a, double omega_b)
{
    return k * twist + c * (omega_a - omega_b);
}

double cc_shaft_twist(double twist, double omega_a, double omega_b, double rate_a, double rate_b, double h)
{
    return twist + (omega_a - omega_b) * h + 0.5 * (rate_a - rate_b) * h * h;
}

double cc_shaft_energy(double k, double twist)
{
    return 0.5 * k * twist * twist;
}

/* the pump's motion: up (the travelling valve closed, the plunger lifting the fluid), down, at rest */
enum { PUMP_DOWN = -1, PUMP_REST = 0, PUMP_UP = 1 };

void cc_string_step(int n, const double* mass, const double* weight, const double* stiffness, double c,
                    const double* pump, double* u, double* v, double* last_u, double* x, double top_next,
                    double dt, double* v_new)
{
    double Fo = pump[0], friction = pump[1], fillage = pump[2];
    double scale = 1.0 / (1.0 + c * dt / 2), keep = (1.0 - c * dt / 2) * scale;
    /* each node: its weight and the tensions of the segments above (up) and below (down) */
    for (int j = 0; j < n; j++) {
        double f = weight[j];
        if (j < n - 1) f += stiffness[j] * (u[j + 1] - u[j]);
        if (j > 0) f -= stiffness[j - 1] * (u[j] - u[j - 1]);
        v_new[j] = keep * v[j] + dt * scale / mass[j] * f;
    }
    /* the pump: the force P on the plunger in its law, the plunger's velocity with it (exact) */
    double b = dt * scale / mass[n - 1], u_pump = u[n - 1], v_free = v_new[n - 1];
    int gas = !(fillage >= 1.0 || isnan(x[CS_U_TOP]) || isnan(x[CS_U_BOTTOM])) &&
              u_pump < x[CS_U_TOP] + (1.0 - fillage) * (x[CS_U_BOTTOM] - x[CS_U_TOP]);
    double p_hi = Fo + friction, p_lo = (gas ? Fo : 0.0) - friction, p_rest = -v_free / b, P;
    int motion;
    if (p_rest > p_hi) {
        P = p_hi;
        motion = PUMP_UP;
    } else if (p_rest < p_lo) {
        P = p_lo;
        motion = PUMP_DOWN;
    } else {
        P = p_rest;
        motion = PUMP_REST;
    }
    int before = (int)x[CS_MOTION];
    if (motion == PUMP_UP && before != PUMP_UP) x[CS_U_BOTTOM] = u_pump;
    else if (motion != PUMP_UP && before == PUMP_UP) x[CS_U_TOP] = u_pump;
    x[CS_MOTION] = motion;
    x[CS_GAS] = gas;
    v_new[n - 1] = v_free + b * P;
    v_new[0] = (top_next - u[0]) / dt;
    /* the polished rod: segment 0's tension, the top half-segment's weight, inertia and drag */
    double mid0 = (v_new[0] + v[0]) / 2;
    double load = stiffness[0] * (u[1] - u[0]) + weight[0] - mass[0] * ((v_new[0] - v[0]) / dt + c * mid0);
    x[CS_LOAD] = load;
    x[CS_WORK] -= load * (dt * mid0);
    double kinetic = 0.0;
    for (int j = 0; j < n; j++) {
        double mid = (v_new[j] + v[j]) / 2;
        kinetic += mass[j] * (mid * mid);
    }
    x[CS_DAMPING] += c * dt * kinetic;
    double travel = dt * ((v_new[n - 1] + v[n - 1]) / 2);
    if (motion == PUMP_REST) {
        x[CS_STOPS] -= P * travel;
    } else {
        double fluid = (motion == PUMP_UP || gas) ? Fo : 0.0;
        x[CS_HYDRAULIC] -= fluid * travel;
        x[CS_FRICTION] -= (P - fluid) * travel;
    }
    for (int j = 0; j < n; j++) {
        last_u[j] = u[j];
        u[j] = u[j] + dt * v_new[j];
        v[j] = v_new[j];
    }
    u[0] = top_next;
    x[CS_T] += dt;
}

void cc_string_advance(int n, const double* mass, const double* weight, const double* stiffness, double c,
                       const double* pump, double* u, double* v, double* last_u, double* x, double top_end,
                       double h, double dt_max, double* scratch)
{
    double steps = ceil(h / dt_max - 1e-9);
    int count = steps < 1.0 ? 1 : (int)steps;
    double start = u[0];
    for (int k = 1; k <= count; k++)
        cc_string_step(n, mass, weight, stiffness, c, pump, u, v, last_u, x, start + (top_end - start) * k / count,
                       h / count, scratch);
}

/* ------------------------------------------------------------------------ the string's design */
static int segments(double length, double segment)
{
    double n = ceil(length / segment - 1e-9);
    return n < 1.0 ? 1 : (n > 2.0 * CC_MAX_SEGMENTS ? 2 * CC_MAX_SEGMENTS + 1 : (int)n);
}

static double taper_area(const double* t) { return PI * (t[1] * t[1]) / 4; }
static double wave_speed(const double* t) { return sqrt(t[2] * taper_area(t) / t[3]); }

int cc_string_nodes(int n_tapers, const double* tapers, const double* d, char* why, int why_size)
{
    double depth = 0.0;
    long total = 0;
    for (int i = 0; i < n_tapers; i++) {
        depth += tapers[4 * i];
        total += segments(tapers[4 * i], d[CD_SEGMENT]);
    }
    if (total > CC_MAX_SEGMENTS) {
        snprintf(why, (size_t)why_size, "segment = %s m cuts the %.6g m string into %ld segments, more than %d: "
                 "valid range [%.4g, inf) m with these tapers", shortest(d[CD_SEGMENT]).text, depth, total, CC_MAX_SEGMENTS,
                 depth / CC_MAX_SEGMENTS);
        return 0;
    }
    for (int i = 0; i < n_tapers; i++) {
        const double* t = tapers + 4 * i;
        double dx = t[0] / segments(t[0], d[CD_SEGMENT]), a = wave_speed(t);
        double dt = d[CD_COURANT] * dx / a;
        if (!(dt >= CC_MIN_STEP)) {
            double E_max = t[3] * pow(d[CD_COURANT] * dx / CC_MIN_STEP, 2) / taper_area(t);
            double courant_min = CC_MIN_STEP * a / dx;
            char also[160] = "";
            if (courant_min <= 1.0)
                snprintf(also, sizeof also, ", or courant at least %.4g (valid range [%.4g, 1])", courant_min,
                         courant_min);
            snprintf(why, (size_t)why_size, "courant = %s and taper %d E = %s Pa (wave speed %.3g m/s over "
                     "%.4g m segments) make the string's internal step %.3g s, below %g s, and a second's steps "
                     "would not end: with the other values as given, taper %d E must be at most %.4g Pa (valid "
                     "range (0, %.4g])%s", shortest(d[CD_COURANT]).text, i + 1, shortest(t[2]).text, a, dx, dt,
                     CC_MIN_STEP, i + 1, E_max, E_max,
                     also);
            return 0;
        }
    }
    double p_discharge = d[CD_P_TUBING] + d[CD_RHO_FLUID] * d[CD_G] * depth;
    double above = depth - d[CD_FLUID_LEVEL];
    double p_intake = d[CD_P_CASING] + d[CD_RHO_FLUID] * d[CD_G] * (above > 0.0 ? above : 0.0);
    double Fo = (p_discharge - p_intake) * (PI * (d[CD_PLUNGER_DIAMETER] * d[CD_PLUNGER_DIAMETER]) / 4);
    if (Fo < 0) {
        snprintf(why, (size_t)why_size, "the fluid load is negative (%g N): the intake pressure exceeds the discharge "
                 "pressure", Fo);
        return 0;
    }
    return (int)total + 1;
}

void cc_string_grid(int n_tapers, const double* tapers, const double* d, double* mass, double* weight,
                    double* stiffness, double* out)
{
    double buoyancy = 1.0 - d[CD_RHO_FLUID] / d[CD_RHO_STEEL];
    double depth = 0.0, travel = 0.0, dt_max = INFINITY, weight_in_air = 0.0;
    int n_nodes = 1;
    for (int i = 0; i < n_tapers; i++) n_nodes += segments(tapers[4 * i], d[CD_SEGMENT]);
    for (int j = 0; j < n_nodes; j++) mass[j] = weight[j] = 0.0;
    int seg = 0;
    for (int i = 0; i < n_tapers; i++) {
        const double* t = tapers + 4 * i;
        int n = segments(t[0], d[CD_SEGMENT]);
        double dx = t[0] / n, a = wave_speed(t);
        for (int k = 0; k < n; k++, seg++) {
            double m = t[3] * dx, w = t[3] * dx * d[CD_G] * buoyancy;
            mass[seg] += m / 2;            /* the node above the segment, then the one below */
            weight[seg] += w / 2;
            stiffness[seg] = t[2] * taper_area(t) / dx;
        }
        double dt = d[CD_COURANT] * dx / a;
        if (dt < dt_max) dt_max = dt;
        depth += t[0];
        travel += t[0] / a;
        weight_in_air += t[3] * t[0];
    }
    /* the nodes below each segment get the other halves, in the reference's order */
    seg = 0;
    for (int i = 0; i < n_tapers; i++) {
        const double* t = tapers + 4 * i;
        int n = segments(t[0], d[CD_SEGMENT]);
        double dx = t[0] / n;
        for (int k = 0; k < n; k++, seg++) {
            mass[seg + 1] += t[3] * dx / 2;
            weight[seg + 1] += t[3] * dx * d[CD_G] * buoyancy / 2;
        }
    }
    double p_discharge = d[CD_P_TUBING] + d[CD_RHO_FLUID] * d[CD_G] * depth;
    double above = depth - d[CD_FLUID_LEVEL];
    double p_intake = d[CD_P_CASING] + d[CD_RHO_FLUID] * d[CD_G] * (above > 0.0 ? above : 0.0);
    out[0] = PI * d[CD_DAMPING] * (depth / travel) / (2 * depth);
    out[1] = (p_discharge - p_intake) * (PI * (d[CD_PLUNGER_DIAMETER] * d[CD_PLUNGER_DIAMETER]) / 4);
    out[2] = dt_max;
    out[3] = weight_in_air * d[CD_G] * buoyancy;
}

void cc_string_hang(int n, const double* weight, const double* stiffness, double t, double top, double* u,
                    double* v, double* x)
{
    /* the weight below each node, from the bottom up; segment j carries the nodes below it */
    double below = weight[n - 1];
    u[0] = top;
    double* tension = v;                 /* v holds the tensions until the positions are summed */
    for (int j = n - 2; j >= 0; j--) {
        tension[j] = below + 0.0;
        below += weight[j];
    }
    double sum = 0.0;
    for (int j = 0; j < n - 1; j++) {
        sum += tension[j] / stiffness[j];
        u[j + 1] = top + sum;
    }
    x[CS_LOAD] = tension[0] + weight[0];
    for (int j = 0; j < n; j++) v[j] = 0.0;
    x[CS_T] = t;
    x[CS_WORK] = x[CS_DAMPING] = 0.0;
}
