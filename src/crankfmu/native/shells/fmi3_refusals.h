/* The FMI 3.0 shells' refusal (fmi3_refusals.c calls it): the message logged whatever loggingOn
 * says, fmi3Error returned (fmi3Error for a null instance). Each shell defines it. */
#ifndef FMI3_REFUSALS_H
#define FMI3_REFUSALS_H

#include "fmi3Functions.h"

fmi3Status fmi3_refuse(fmi3Instance instance, const char* message);

#endif
