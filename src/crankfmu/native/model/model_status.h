/* What every native model (crank_model.h's mechanism, component_model.h's components) and the one
 * model API in front of them (fmu_model.h) share: their statuses, the phases of an instance, and
 * how a message reaches the host (the shell's logger: whatever loggingOn says). */
#ifndef MODEL_STATUS_H
#define MODEL_STATUS_H

#include <stdarg.h>

enum { CM_OK = 0, CM_ERROR = 1 };
enum { CM_INSTANTIATED, CM_INITIALIZATION, CM_STEPPING, CM_TERMINATED, CM_FAILED };
/* what a message is: the shells map these to their status values */
enum { CM_LOG_OK, CM_LOG_WARNING, CM_LOG_ERROR };

typedef void (*CmLogger)(void* host, int kind, const char* message);

/* a refusal: the message, formatted, to log as an error (log may be NULL); returns CM_ERROR */
int cm_refusal(CmLogger log, void* host, const char* format, va_list args);

#endif
