/* What hosts read besides the state: the [[outputs]] and the ports' coordinates, and the joint
 * reactions, each from its table at the crank angle (crank_kernel.h; the tables: dynamics/
 * tabulated.py's QuantityTable and ReactionTable). A reaction is linear in the crank's
 * acceleration, omega1^2, omega1, the switched loads' values and the ports' inputs, with
 * coefficients that are functions of phi1 alone: its value is their weighted sum. */
#include "crank_kernel_internal.h"

#include <stddef.h>

int ck_reaction_weights(const double* S, double t, double omega, double epsilon, const CkTables* T, const double* P,
                        double* out)
{
    int n = 0;
    out[n++] = 1.0;
    out[n++] = epsilon;
    out[n++] = omega * omega;
    out[n++] = omega;
    /* the mode at t: a step ends on every event, so before the step's end it is the step's mode */
    int within = t < S[CK_T];
    double direction = within ? S[CK_STEP_DIRECTION] : S[CK_DIRECTION];
    int k = (int)(within ? S[CK_STEP_INTERVAL] : S[CK_INTERVAL]);
    const double* forces = T->forces + (size_t)k * 2 * T->n_sliders;
    for (int s = 0; s < T->n_sliders; s++)      /* (a law's column: 1 both ways, at rest too) */
        out[n++] = ck_column_factor(forces[s], forces[T->n_sliders + s], direction) * ck_column_speed(T, s, omega);
    double dt = t - P[CK_T_INPUT];
    for (int i = 0; i < T->n_ports; i++) out[n++] = P[CK_PORT_INPUT + i] + P[CK_PORT_RATE + i] * dt;
    return n;
}

void ck_quantity_values(const double* coefficients, int n_coordinates, int n, const double* winding,
                        int n_quantities, const int* coordinate, const int* order, double phi, double omega,
                        double epsilon, double* scratch, double* out)
{
    /* the kinematics: periodic over one turn, whatever the machine's cycle */
    ck_periodic_cubics(coefficients, 3 * n_coordinates, n, CK_TWO_PI, phi, scratch);
    for (int k = 0; k < n_quantities; k++) {
        int c = coordinate[k];
        double q = scratch[3 * c] + winding[c] * phi, dq = scratch[3 * c + 1], ddq = scratch[3 * c + 2];
        out[k] = order[k] == 0 ? q : (order[k] == 1 ? dq * omega : ddq * omega * omega + dq * epsilon);
    }
}

int ck_reaction_values(const double* coefficients, int n_reactions, int n_terms, int n, const double* S, double t,
                       double phi, double omega, double epsilon, const CkTables* T, const double* P, double* scratch,
                       double* out)
{
    double* weights = scratch + (size_t)n_reactions * n_terms;
    if (ck_reaction_weights(S, t, omega, epsilon, T, P, weights) != n_terms) return -1;
    /* the loads' terms: periodic over the machine's cycle, as the reduced model's */
    ck_periodic_cubics(coefficients, n_reactions * n_terms, n, T->period, phi, scratch);
    for (int r = 0; r < n_reactions; r++) {
        const double* terms = scratch + (size_t)r * n_terms;
        double value = 0.0;
        for (int j = 0; j < n_terms; j++) value += weights[j] * terms[j];
        out[r] = value;
    }
    return 0;
}
