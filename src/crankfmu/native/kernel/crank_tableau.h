/* The Dormand-Prince 5(4) tableau with its quartic dense output.
 *
 * Dormand and Prince (1980), "A family of embedded Runge-Kutta formulae", J. Comp. Appl. Math. 6;
 * the dense output is Shampine's (1986), "Some practical Runge-Kutta formulas", Math. Comp. 46,
 * the interpolant scipy's RK45 and Hairer's DOPRI5 use. The seventh stage is the first of the next
 * step (FSAL): E has seven entries, the error estimate h * sum(E[s] K[s]) of the step.
 * Written as the same quotients as integrators/tableau.py (a test compares them bit for bit).
 */
#ifndef CRANK_TABLEAU_H
#define CRANK_TABLEAU_H

#define CK_N_STAGES 6
#define CK_ERROR_ESTIMATOR_ORDER 4

static const double CK_A[CK_N_STAGES][5] = {
    {0.0, 0.0, 0.0, 0.0, 0.0},
    {1.0 / 5, 0.0, 0.0, 0.0, 0.0},
    {3.0 / 40, 9.0 / 40, 0.0, 0.0, 0.0},
    {44.0 / 45, -56.0 / 15, 32.0 / 9, 0.0, 0.0},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729, 0.0},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
};
/* the stages' nodes c: stage s is evaluated at t + c[s] h */
static const double CK_C[CK_N_STAGES] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0};
static const double CK_B[CK_N_STAGES] = {35.0 / 384, 0.0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84};
static const double CK_E[CK_N_STAGES + 1] = {-71.0 / 57600, 0.0, 71.0 / 16695, -71.0 / 1920, 17253.0 / 339200,
                                             -22.0 / 525, 1.0 / 40};
/* dense output: y(t + x h) = y + h * sum_s K[s] * (P[s] . [x, x^2, x^3, x^4]) */
static const double CK_P[CK_N_STAGES + 1][4] = {
    {1.0, -8048581381.0 / 2820520608, 8663915743.0 / 2820520608, -12715105075.0 / 11282082432},
    {0.0, 0.0, 0.0, 0.0},
    {0.0, 131558114200.0 / 32700410799, -68118460800.0 / 10900136933, 87487479700.0 / 32700410799},
    {0.0, -1754552775.0 / 470086768, 14199869525.0 / 1410260304, -10690763975.0 / 1880347072},
    {0.0, 127303824393.0 / 49829197408, -318862633887.0 / 49829197408, 701980252875.0 / 199316789632},
    {0.0, -282668133.0 / 205662961, 2019193451.0 / 616988883, -1453857185.0 / 822651844},
    {0.0, 40617522.0 / 29380423, -110615467.0 / 29380423, 69997945.0 / 29380423},
};

#endif
