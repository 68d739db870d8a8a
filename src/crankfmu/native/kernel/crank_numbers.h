/* Numbers in messages, written once for every C part of crankfmu (the FMUs' shells, the components'
 * refusals). */
#ifndef CRANK_NUMBERS_H
#define CRANK_NUMBERS_H

/* A number in a message as its user wrote it, as Python's repr writes it (the CLI's and the
 * Python FMU's messages): the fewest significant digits that read back as the same double (0.1, not
 * 0.10000000000000001; 1e-11, not 9.9999999999999994e-12), in fixed notation from 1e-4 up to
 * 1e16 with at least one decimal (2.0, 100.0), else in exponent notation (1e-11, 1e+300). */
typedef struct { char text[48]; } Number;
Number shortest(double x);

#endif
