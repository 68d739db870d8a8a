/* The test hosts' logger (fmu_driver.c, system_driver.c): every message an FMU logs, on stdout as
 * "log [instance] status=S category=C: message", where a test reads it. */
#ifndef HOST_LOGGER_H
#define HOST_LOGGER_H

#include <stdarg.h>
#include <stdio.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    va_list ap;
    (void)env;
    va_start(ap, message);
    printf("log [%s] status=%d category=%s: ", name, (int)status, category ? category : "");
    vprintf(message, ap);
    printf("\n");
    va_end(ap);
}

#endif
