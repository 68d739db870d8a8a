/* The beam pumping well as one model (crank_well.h). */
#include "crank_well.h"

#include <math.h>
#include <string.h>

static const double CW_TWO_PI = 2.0 * 3.14159265358979323846;

CK_API double cw_rope_position(const CwWell* w, double phi)
{
    /* phi modulo one turn in [0, 2 pi), as Python's % on floats */
    double x = fmod(phi, CW_TWO_PI);
    if (x != 0.0) {
        if (x < 0.0) x += CW_TWO_PI;
    } else {
        x = 0.0;
    }
    int i = (int)(x / w->rope_h);
    if (i > w->n_rope - 1) i = w->n_rope - 1;
    const double* c = w->rope_cubics + 4 * (long)i;
    double u = x - w->rope_x[i];
    return ((c[0] * u + c[1]) * u + c[2]) * u + c[3];
}

/* the unit started at (t, y) with the polished rod load linear in time from load at t */
static void start_unit(const CwWell* w, double t, double load, double rate)
{
    for (int i = 0; i < w->n_ports; i++) {
        w->P[CK_PORT_INPUT + i] = i == w->i_port ? load : 0.0;
        w->P[CK_PORT_RATE + i] = i == w->i_port ? rate : 0.0;
    }
    w->P[CK_T_INPUT] = t;
    memset(w->S, 0, sizeof(double) * CK_STATE_SIZE);
    ck_begin(w->S, t, w->y, w->tables, w->P, w->row);
}

/* the load the unit feels: the first segment's tension and the top half-segment's buoyant weight */
static double static_load(const CwWell* w)
{
    return w->stiffness[0] * (w->u[1] - w->u[0]) + w->weight[0];
}

static int step(const CwWell* w, double* clock)
{
    int n = w->n;
    double t = clock[0], dt = w->dt;
    double* saved_u = w->scratch;
    double* saved_v = saved_u + n;
    double* saved_last = saved_v + n;
    double* saved_x = saved_last + n;
    double* step_scratch = saved_x + CS_SIZE;
    memcpy(saved_u, w->u, sizeof(double) * n);
    memcpy(saved_v, w->v, sizeof(double) * n);
    memcpy(saved_last, w->last_u, sizeof(double) * n);
    memcpy(saved_x, w->x, sizeof(double) * CS_SIZE);
    double load_a = clock[1], load_b = clock[1];
    for (int pass = 0; pass < 2; pass++) {
        start_unit(w, t, load_a, (load_b - load_a) / dt);
        int status = ck_advance(w->S, t + dt, t + dt, w->tables, w->P, w->row);
        if (status != 0) return status;
        double phi = w->row[0];
        if (pass) {
            memcpy(w->u, saved_u, sizeof(double) * n);
            memcpy(w->v, saved_v, sizeof(double) * n);
            memcpy(w->last_u, saved_last, sizeof(double) * n);
            memcpy(w->x, saved_x, sizeof(double) * CS_SIZE);
        }
        cc_string_step(n, w->mass, w->weight, w->stiffness, w->c, w->pump, w->u, w->v, w->last_u, w->x,
                       cw_rope_position(w, phi), dt, step_scratch);
        load_b = static_load(w);
    }
    ck_dense(w->S, t + dt, w->y);
    clock[0] = t + dt;
    clock[1] = load_b;
    return 0;
}

CK_API int cw_run(const CwWell* w, double* clock, double phi_stop, int max_steps, double* samples, int* status)
{
    int k = 0;
    *status = 0;
    while (k < max_steps && w->y[0] < phi_stop) {
        *status = step(w, clock);
        if (*status != 0) break;
        if (samples) {
            double* s = samples + (long)CW_SAMPLE_SIZE * k;
            const double* r = w->row;
            int n = w->n;
            s[0] = clock[0];
            s[1] = r[0];                     /* phi1 */
            s[2] = r[1];                     /* omega1 */
            s[3] = r[5];                     /* epsilon1 */
            s[4] = r[6];                     /* M_motor */
            s[5] = w->u[0];
            s[6] = clock[1];
            s[7] = w->u[n - 1];
            s[8] = w->stiffness[n - 2] * (w->u[n - 1] - w->u[n - 2]);
            s[9] = w->x[CS_WORK];
            s[10] = w->x[CS_HYDRAULIC];
            s[11] = w->x[CS_DAMPING];
            s[12] = w->x[CS_FRICTION];
            s[13] = w->x[CS_STOPS];
        }
        k++;
    }
    return k;
}
