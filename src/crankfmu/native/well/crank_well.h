/* The beam pumping well as one model: the unit's movement equation (the kernel) and the rod string
 * (the components' steps) advanced together on the string's time grid. crankfmu/well.py's
 * CoupledWell.step states the same step in Python, the reference tests/test_well_c.py compares
 * this with to the bit; crankfmu well runs this one.
 *
 * One step of dt: the polished rod load is linear in time between its values at the step's ends;
 * the unit's step needs the load at the end, which needs the string's step, which needs the
 * polished rod's position at the end, which needs the unit's step: two passes to the fixed point
 * (the load's sensitivity to the unit's step over one string step is about 1e-4). */
#ifndef CRANK_WELL_H
#define CRANK_WELL_H

#include "crank_components.h"
#include "crank_kernel.h"

/* a sample after each step: t, phi1, omega1, epsilon1, M_motor, s (the polished rod, m down), F
 * (its load, N), u_pump, F_pump, work, hydraulic, damping, friction, stops (crankfmu/well.py's
 * FIELDS) */
enum { CW_SAMPLE_SIZE = 14 };

typedef struct {
    /* the unit: the kernel's state, tables and parameters (the rope port's input is the port
     * i_port of n_ports), its output row and its state y (CK_N_Y) */
    double* S;
    const CkTables* tables;
    double* P;
    double* row;
    double* y;
    int i_port, n_ports;
    /* the rope port's coordinate s(phi1) on one turn: n_rope cubics c3 u^3 + c2 u^2 + c1 u + c0
     * (4 per interval, u from the breakpoint rope_x[i]), intervals of rope_h rad */
    const double* rope_x;
    const double* rope_cubics;
    int n_rope;
    double rope_h;
    /* the string (crank_components.h): its grid, Gibbs' c, the pump's (Fo, friction, fillage), and
     * its state u, v, last_u and scalars x (CS_SIZE) */
    int n;
    const double* mass;
    const double* weight;
    const double* stiffness;
    double c;
    const double* pump;
    double* u;
    double* v;
    double* last_u;
    double* x;
    double dt;
    /* 4 n + CS_SIZE doubles */
    double* scratch;
} CwWell;

/* The rope's position s(phi1) (m): the cubic of phi1 modulo one turn. */
CK_API double cw_rope_position(const CwWell* w, double phi);

/* Steps until the crank angle y[0] reaches phi_stop, or max_steps steps. clock: (t s, the polished
 * rod load at t N), advanced; samples (max_steps x CW_SAMPLE_SIZE, or NULL): one row per step.
 * Returns the steps taken; *status is 0, or the kernel's refusal (ck_advance's) that stopped it. */
CK_API int cw_run(const CwWell* w, double* clock, double phi_stop, int max_steps, double* samples, int* status);

#endif
