/* The kernel's constants and rules one by one (crank_kernel.h): its state's layout (native/
 * __init__.py reads its array indices from it), its tableau, each hybrid rule of crank_modes.h and
 * the switch intervals' lookup, called with plain arrays so tests/test_modes.py can compare them
 * with the Python engine's statement of the same rules, and the digest of the sources the
 * library was compiled from. Nothing here runs in a step. */
#include "crank_kernel_internal.h"

#include <math.h>

#ifndef CK_SOURCE_DIGEST
#define CK_SOURCE_DIGEST "unknown"
#endif

const char* ck_source_digest(void) { return CK_SOURCE_DIGEST; }

int ck_tableau(double* out, int n)
{
    int k = 0;
    for (int i = 0; i < CK_N_STAGES; i++)
        for (int j = 0; j < 5; j++, k++) if (k < n) out[k] = CK_A[i][j];
    for (int i = 0; i < CK_N_STAGES; i++, k++) if (k < n) out[k] = CK_B[i];
    for (int i = 0; i < CK_N_STAGES + 1; i++, k++) if (k < n) out[k] = CK_E[i];
    for (int i = 0; i < CK_N_STAGES + 1; i++)
        for (int j = 0; j < 4; j++, k++) if (k < n) out[k] = CK_P[i][j];
    for (int i = 0; i < CK_N_STAGES; i++, k++) if (k < n) out[k] = CK_C[i];
    return k;
}

const char* ck_status_text(int status)
{
    switch (status) {
    case CK_UNDERFLOW: return "step size underflow";
    case CK_TOO_MANY_STEPS:
        return "over 1e7 integration steps in one communication step: the inputs, their derivatives or the "
               "parameters spin the crank beyond any use; take smaller communication steps if they are meant";
    case CK_BAD_STATE: return "a corrupted state: the kernel's state holds no mode it can have written";
    default: return "an unknown refusal";
    }
}

double ck_rule(int rule, const double* a)
{
    switch (rule) {
    case 0: return ck_line_torque(a[0], a[1], a[2]);
    case 1: return ck_acceleration(a[0], a[1], a[2], a[3], a[4], a[5]);
    case 2: return ck_equivalent_torque(a[0], a[1], a[2], a[3]);
    case 3: return ck_kinetic_energy(a[0], a[1]);
    case 4: return ck_motor_of_speed(a[0], a[1]);
    case 5: return ck_direction_of_speed(a[0]);
    case 6: return ck_motor_on_switch(a[0], a[1], a[2]);
    case 7: return ck_direction_at_rest(a[0], a[1]);
    case 8: return ck_motor_at_rest(a[0], a[1]);
    case 9: return ck_motor_after_sliding((int)a[0]);
    case 10: return ck_turns_forces((int)a[0], a[1], (int)a[2]);
    case 11: return ck_event_active((int)a[0], a[1], a[2], a[3], (int)a[4], a[5]);
    case 12: return ck_event_value((int)a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9]);
    case 13: return ck_event_rising((int)a[0], a[1], a[2]);
    case 14: return ck_crosses(a[0], a[1], (int)a[2]);
    case 15: return ck_drive_torque(a[0], a[1], a[2], a[3], a[4], a[5]);
    case 16: return ck_direction_imposed(a[0]);
    case 17: return ck_column_factor(a[0], a[1], a[2]);
    default: return NAN;
    }
}

int ck_interval_of_rule(const double* sw, int m, double phi, double direction, double* bounds)
{
    return ck_interval_of(sw, m, phi, direction, &bounds[0], &bounds[1]);
}

int ck_next_interval_rule(const double* sw, int m, int k, double* bounds, int forward)
{
    return ck_next_interval(sw, m, k, &bounds[0], &bounds[1], forward);
}

int ck_layout(int* out, int n)
{
    const int values[] = {CK_T, CK_Y, CK_F, CK_H, CK_MOTOR, CK_DIRECTION, CK_INTERVAL, CK_PHI_LO, CK_PHI_HI,
                          CK_T_PREV, CK_Y_PREV, CK_K, CK_N_RHS, CK_STEP_MOTOR, CK_STEP_DIRECTION, CK_STEP_INTERVAL,
                          CK_N_STEPS, CK_STATE_SIZE, CK_N_Y, CK_PARAM_SIZE, CK_OUT_SIZE, CK_STEADY_SIZE,
                          CK_N_STAGES, CK_N_SLOTS, CK_MAX_FUNCTIONS, CK_N_PLAIN, CK_MAX_FRICTIONS,
                          CK_MAX_FRICTION_FUNCTIONS};
    int count = (int)(sizeof values / sizeof values[0]);
    for (int i = 0; i < count && i < n; i++) out[i] = values[i];
    return count;
}
