/* What hosts read besides the state: the [[outputs]] and the ports' coordinates, and the joint
 * reactions, each from its table at the crank angle (crank_kernel.h; the tables: dynamics/
 * tabulated.py's QuantityTable and reaction_table.py's ReactionTable). A reaction is linear in the crank's
 * acceleration, omega1^2, omega1, the switched loads' values and the ports' inputs, with
 * coefficients that are functions of phi1 alone: its value is their weighted sum. */
#include "crank_kernel_internal.h"

#include <stddef.h>

int kernel_reaction_weights(double t, double omega, double epsilon, double direction, double interval,
                            const CkTables* T, const double* P, double* out)
{
    int n = 0;
    out[n++] = 1.0;
    out[n++] = epsilon;
    out[n++] = omega * omega;
    out[n++] = omega;
    const double* forces = T->forces + (size_t)interval * 2 * T->n_sliders;
    for (int s = 0; s < T->n_sliders; s++)      /* (a law's column: 1 both ways, at rest too) */
        out[n++] = ck_column_factor(forces[s], forces[T->n_sliders + s], direction) * ck_column_speed(T, s, omega);
    double dt = t - P[CK_T_INPUT];
    for (int i = 0; i < T->n_ports; i++) out[n++] = P[CK_PORT_INPUT + i] + P[CK_PORT_RATE + i] * dt;
    return n;
}

int ck_reaction_weights(const double* S, double t, double omega, double epsilon, const CkTables* T, const double* P,
                        double* out)
{
    /* the mode at t: a step ends on every event, so before the step's end it is the step's mode */
    int within = t < S[CK_T];
    return kernel_reaction_weights(t, omega, epsilon, within ? S[CK_STEP_DIRECTION] : S[CK_DIRECTION],
                                   within ? S[CK_STEP_INTERVAL] : S[CK_INTERVAL], T, P, out);
}

int ck_friction_values(const double* S, double t, const double* y, double epsilon, const CkTables* T,
                       const double* P, double* out)
{
    if (T->friction == NULL) return 0;
    if (!kernel_mode_ok(S, T)) return CK_BAD_STATE;
    const double* mode = kernel_mode_at(S, t);
    int nf = T->friction->n_f;
    out[nf] = kernel_friction_imposed(t, y[0], y[1], epsilon, mode[1], mode[2], T, P, out);
    return nf;
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
    int n_weights = ck_reaction_weights(S, t, omega, epsilon, T, P, weights);
    if (T->friction != NULL && n_terms == n_weights + T->friction->n_f) {
        /* with joint friction, each friction's value weighs its unit term (the mode at t as the
         * weights take it) */
        int within = t < S[CK_T];
        kernel_friction_imposed(t, phi, omega, epsilon, within ? S[CK_STEP_DIRECTION] : S[CK_DIRECTION],
                                within ? S[CK_STEP_INTERVAL] : S[CK_INTERVAL], T, P, weights + n_weights);
        n_weights += T->friction->n_f;
    }
    if (n_weights != n_terms) return -1;
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
