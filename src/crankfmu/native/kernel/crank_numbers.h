/* Numbers in messages, and the wording of a value out of range, written once for every C part of
 * crankfmu (the FMUs' shells, the mechanism's and the components' refusals). */
#ifndef CRANK_NUMBERS_H
#define CRANK_NUMBERS_H

/* A number in a message as its user wrote it, as Python's repr writes it (the CLI's and the
 * Python FMU's messages): the fewest significant digits that read back as the same double (0.1, not
 * 0.10000000000000001; 1e-11, not 9.9999999999999994e-12), in fixed notation from 1e-4 up to
 * 1e16 with at least one decimal (2.0, 100.0), else in exponent notation (1e-11, 1e+300). */
typedef struct { char text[48]; } Number;
Number shortest(double x);

/* The refusal of a parameter's value outside its valid range, in the Python FMU's words
 * (parameters.Parameter.check, prefixed with the name by fmi/python/core.py): "J_flywheel: parameter
 * J_flywheel = -1.0 is out of range: valid range [0, inf) kg.m2 (flywheel inertia ...)"; the
 * description in parentheses where there is one. */
typedef struct { char text[1024]; } Refusal;
Refusal out_of_range(const char* name, double x, const char* range, const char* description);

#endif
