/* The native FMUs' messages to a host (fmi2_messages.h). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2_messages.h"

void fmu_log(const fmi2CallbackFunctions* cb, fmi2String instance, int logging_on, fmi2Status status,
             const char* category, const char* format, ...)
{
    if (!cb || !cb->logger) return;
    if (status < fmi2Warning && !logging_on) return;     /* warnings and errors: always */
    char text[1024], escaped[2048];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    /* the message is the text itself, its '%' doubled: a host that formats it (as FMI says)
     * prints the text, and one that does not (a Python callback cannot read varargs) reads it */
    size_t k = 0;
    for (const char* p = text; *p && k + 2 < sizeof escaped; p++) {
        if (*p == '%') escaped[k++] = '%';
        escaped[k++] = *p;
    }
    escaped[k] = '\0';
    cb->logger(cb->componentEnvironment, instance, status, category, escaped);
}
