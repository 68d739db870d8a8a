/* What the native FMUs' FMI 2.0 shells (crank_fmi2.c, component_fmi2.c) say to a host, written
 * once: the logger call (warnings and errors whatever loggingOn says) and numbers as a user wrote
 * them. */
#ifndef FMI2_MESSAGES_H
#define FMI2_MESSAGES_H

#include "fmi2Functions.h"

/* a message to the host's logger: always for a warning or an error, else only with logging on */
void fmu_log(const fmi2CallbackFunctions* cb, fmi2String instance, int logging_on, fmi2Status status,
             const char* category, const char* format, ...);

/* A number in a message as its user wrote it, as Python's repr writes it (the CLI's and the
 * Python FMU's messages): the fewest significant digits that read back as the same double (0.1, not
 * 0.10000000000000001; 1e-11, not 9.9999999999999994e-12), in fixed notation from 1e-4 up to
 * 1e16 with at least one decimal (2.0, 100.0), else in exponent notation (1e-11, 1e+300). */
typedef struct { char text[48]; } Number;
Number shortest(double x);

#endif
