/* What the native FMUs' FMI 2.0 shell (fmi2_shell.c) says to a host, written
 * once: the logger call (warnings and errors whatever loggingOn says) and numbers as a user wrote
 * them. */
#ifndef FMI2_MESSAGES_H
#define FMI2_MESSAGES_H

#include "crank_numbers.h"
#include "fmi2Functions.h"

/* a message to the host's logger: always for a warning or an error, else only with logging on */
void fmu_log(const fmi2CallbackFunctions* cb, fmi2String instance, int logging_on, fmi2Status status,
             const char* category, const char* format, ...);



#endif
