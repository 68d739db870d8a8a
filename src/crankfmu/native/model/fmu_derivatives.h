/* The derivatives a master couples with, for every native FMU whose model is smooth between its
 * events (a mechanism in its mode, the drives, the cushion): directional derivatives of the
 * unknowns (outputs, the states' derivatives) with respect to the knowns (the continuous states
 * and the inputs), and the outputs' first and second time derivatives along the trajectory the
 * next step follows.
 *
 * A model hands its equations over as one function of z = (its states, then its inputs): the
 * values of the unknowns asked and the states' rates there, the mode held (a mechanism's motor
 * line, slider side and switch interval stay those of the current point). Those equations are
 * the FMU's own (the tables, the kernel's right-hand side, the drive's circuit), and their
 * derivatives are taken here by central differences with one Richardson extrapolation: on the
 * smooth pieces these functions are (cubics in phi1 between table knots, polynomials in the speed
 * and linear in the inputs), the error is below 1e-10 relative, where a master's linearisation
 * needs 1e-3. A directional and an adjoint derivative are one Jacobian's product and its
 * transpose's, so they agree to rounding. */
#ifndef FMU_DERIVATIVES_H
#define FMU_DERIVATIVES_H

#include <stddef.h>

typedef struct {
    void* model;
    int n_states;      /* z's first n_states are the continuous states, the rest the inputs */
    int n_z;
    const double* z;   /* the current point */
    const double* scale;   /* each z's size: the differences step 1e-5 of it */
    const double* input_rates;   /* the inputs' rates over the next step (0: held) */
    size_t n_values;   /* how many unknowns evaluate writes */
    /* the unknowns (n_values) and the states' rates (n_states; either may be NULL) at z: 0, or -1
     * where the model cannot be evaluated there (non-finite values) */
    int (*evaluate)(void* model, const double* z, double* values, double* rates);
    /* z's index of a known's value reference (a state, or an output that is one; an input), or -1 */
    int (*known)(void* model, unsigned vr);
} FdModel;

enum { FD_OK = 0, FD_NOT_FINITE = -1, FD_NOT_A_KNOWN = -2 };

/* jacobian[i * n_knowns + k] = d value_i / d (the known knowns[k]) at p->z: FD_OK, FD_NOT_FINITE, or
 * FD_NOT_A_KNOWN with *refused the first known's place in knowns */
int fd_jacobian(const FdModel* p, const unsigned* knowns, size_t n_knowns, double* jacobian, size_t* refused);

/* the values' first and second time derivatives (either may be NULL) along the trajectory from p->z,
 * the inputs changing at p->input_rates: FD_OK or FD_NOT_FINITE */
int fd_time_derivatives(const FdModel* p, double* first, double* second);

#endif
