/* The native mechanism FMU's refusal of a design the C mechanism model cannot build (crank_model.c's
 * cm_ensure_tables), in the engine's words: the crank angle and the reason, the geometry parameters,
 * and for each one set to another value than the FMU's start the bound it must respect (found by
 * bisection on the coarse assembly check, as Scenario._explain_assembly does). */
#include "crank_model_internal.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

static double degrees_in_turn(double phi1)
{
    double d = fmod(phi1 * (180.0 / 3.141592653589793), 360.0);
    return d < 0 ? d + 360.0 : d;
}

/* whether the program at these values assembles over the turn (the coarse check, as the engine's
 * search for a bound) */
static int assembles(const Model* m, const double* values)
{
    mm_model probe;
    int ok = mm_bind(&probe, &m->d->program, values, m->d->n_program_parameters) == MM_OK && mm_check(&probe, 1) == MM_OK;
    mm_free(&probe);
    return ok;
}

/* "; with the other parameters as given the crank turns fully only for l3 > 0.35 m (asked 0.31)"
 * for each geometry parameter set to another value than the FMU's start (Scenario._explain_assembly) */
static void bounds(const Model* m, const double* values, char* text, size_t size)
{
    size_t used = strlen(text);
    for (int g = 0; g < m->d->n_geometry_parameters; g++) {
        int i = m->d->geometry_parameters[g], vr = m->d->program_parameter_vr[i];
        if (vr < 0 || values[i] == m->d->variables[vr].start) continue;
        double *trial = m->scratch + m->d->n_program_parameters + 1, good = m->d->variables[vr].start, bad = values[i];
        memcpy(trial, values, sizeof(double) * m->d->n_program_parameters);
        trial[i] = good;
        if (!assembles(m, trial)) continue;
        for (int k = 0; k < 40; k++) {
            trial[i] = 0.5 * (good + bad);
            if (assembles(m, trial)) good = trial[i]; else bad = trial[i];
        }
        used += (size_t)snprintf(text + used, used < size ? size - used : 0,
                                 "; with the other parameters as given the crank turns fully only for %s %s %.6g %s "
                                 "(asked %g)", m->d->variables[vr].name, good < values[i] ? "<" : ">", good,
                                 m->d->variables[vr].unit, values[i]);
        if (used >= size) break;
    }
}

/* the refusal of a design the C model cannot build, in the engine's words */
void cm_design_refusal(const Model* m, const char* call, int status, const double* values, char* out, size_t size)
{
    const mm_model* mm = &m->mechanism;
    char reason[512], text[2048];
    double at = degrees_in_turn(mm->error_angle);
    switch (status) {
    case MM_NO_SOLUTION: snprintf(reason, sizeof reason, "the contour equations have no real solution"); break;
    case MM_SINGULAR: snprintf(reason, sizeof reason, "the contour Jacobian is singular (dead point)"); break;
    case MM_NO_CONVERGENCE: snprintf(reason, sizeof reason, "Newton's method did not converge"); break;
    case MM_GUESS: snprintf(reason, sizeof reason, "Newton's method did not converge from the file's guess"); break;
    case MM_LOST: snprintf(reason, sizeof reason, "the continuation lost the assembly"); break;
    case MM_BRANCH:
        snprintf(reason, sizeof reason, "after one crank turn %s does not return to its start (branch change)",
                 m->d->unknown_names[mm->error_index > 0 ? mm->error_index - 1 : 0]);
        break;
    case MM_DEAD_POINT:
        snprintf(reason, sizeof reason, "the mechanism passes a dead point (the contour Jacobian's determinant changes "
                 "sign; or the closed form jumps between assembly branches)");
        break;
    case MM_LOCKS:
        snprintf(reason, sizeof reason, "the mechanism locks at a dead point (conditioning %.2e < %g)", mm->error_value,
                 m->d->program.min_conditioning);
        break;
    default: reason[0] = 0;
    }
    if (reason[0]) {
        size_t used = (size_t)snprintf(text, sizeof text, "%s: %s: the geometry cannot be assembled over the whole crank "
                                       "turn: at phi1 = %.3f deg %s (branch: %s; geometry parameters ", call,
                                       m->d->mechanism_name, at, reason, m->d->mechanism_branch);
        for (int g = 0; g < m->d->n_geometry_parameters && used < sizeof text; g++)
            used += (size_t)snprintf(text + used, sizeof text - used, "%s%s = %g", g ? ", " : "",
                                     m->d->program_parameter_name[m->d->geometry_parameters[g]], values[m->d->geometry_parameters[g]]);
        if (used < sizeof text) snprintf(text + used, sizeof text - used, ")");
        bounds(m, values, text, sizeof text);
        snprintf(out, size, "%s", text);
        return;
    }
    switch (status) {
    case MM_CLOSED_FORM:
        snprintf(out, size, "%s: %s: the closed form does not satisfy the contour equations (residual %.3g m); check the "
                       "mechanism file", call, m->d->mechanism_name, mm->error_value);
        return;
    case MM_CHECK:
        snprintf(out, size, "%s: %s: %s = %g must be >= 0 and finite", call, m->d->mechanism_name,
                       m->d->check_names[mm->error_index], mm->error_value);
        return;
    case MM_NOT_ROCKER:
        snprintf(out, size, "%s: %s: a dead-point moment's link is not a rocker with two extreme positions per crank turn "
                       "(found %g extremes)", call, m->d->mechanism_name, mm->error_value);
        return;
    case MM_NO_REVERSAL:
        snprintf(out, size, "%s: %s: a slider force's point, or a direction-dependent load's coordinate, never reverses "
                       "over the turn", call, m->d->mechanism_name);
        return;
    case MM_NOT_TABULATED:
        if (mm->error_jumps) {
            snprintf(out, size, "%s: %s: function %d of the tables cannot be tabulated with 65536 intervals (error %.2g): "
                           "it jumps by %.4g near phi1 = %.3f deg, a discontinuity in the crank angle (a closed form's "
                           "branch cut?), not a dead point", call, m->d->mechanism_name, mm->error_index, mm->error_value,
                           mm->error_step, at);
            return;
        }
        snprintf(out, size, "%s: %s: function %d of the tables cannot be tabulated with 65536 intervals (error %.2g): it "
                       "changes fastest near phi1 = %.3f deg; the mechanism is too close to a dead point there", call,
                       m->d->mechanism_name, mm->error_index, mm->error_value, at);
        return;
    case MM_JUMPS: {
        int angle = m->d->program.angle_column[mm->error_index];
        snprintf(out, size, "%s: %s: the closed form of %s jumps by %.4g %s at phi1 = %.4f deg (%s); write it continuous "
                       "along the turn, or give a guess instead of a closed form", call, m->d->mechanism_name,
                       m->d->unknown_names[mm->error_index - 1], mm->error_value, angle ? "rad" : "m",
                       mm->error_angle * (180.0 / 3.141592653589793),
                       angle ? "not a whole turn, so it cannot be made continuous" : "a length cannot jump");
        return;
    }
    case MM_NOT_FINITE:
        snprintf(out, size, "%s: %s: a function of the tables is %g at phi1 = %.3f deg (not finite, or beyond 1e150)",
                       call, m->d->mechanism_name, mm->error_value, at);
        return;
    case MM_TOO_MANY_SWITCHES:
        snprintf(out, size, "%s: %s: over %d switch angles of the loads in one turn", call, m->d->mechanism_name,
                       MM_MAX_SWITCHES);
        return;
    default:
        snprintf(out, size, "%s: %s: out of memory building the tables", call, m->d->mechanism_name);
        return;
    }
}
