/* A refusal's message to the host (model_status.h): what every model and the one model API say
 * with, below all of them. */
#include "model_status.h"

#include <stdio.h>

int cm_refusal(CmLogger log, void* host, const char* format, va_list args)
{
    char text[1024];
    vsnprintf(text, sizeof text, format, args);
    if (log) log(host, CM_LOG_ERROR, text);
    return CM_ERROR;
}
