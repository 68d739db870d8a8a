/* Numbers in messages (crank_numbers.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crank_numbers.h"

Number shortest(double x)
{
    Number n;
    if (!isfinite(x)) {
        snprintf(n.text, sizeof n.text, "%s", x != x ? "nan" : (x > 0 ? "inf" : "-inf"));
        return n;
    }
    int digits = 1;
    for (; digits < 17; digits++) {
        snprintf(n.text, sizeof n.text, "%.*e", digits - 1, x);
        if (strtod(n.text, NULL) == x) break;
    }
    snprintf(n.text, sizeof n.text, "%.*e", digits - 1, x);
    int exponent = atoi(strchr(n.text, 'e') + 1);
    if (x != 0.0 && (exponent < -4 || exponent >= 16)) return n;          /* 1e-11, 1e+300 */
    int decimals = digits - 1 - exponent;
    snprintf(n.text, sizeof n.text, "%.*f", decimals > 1 ? decimals : 1, x);
    return n;
}


Refusal out_of_range(const char* name, double x, const char* range, const char* description)
{
    Refusal r;
    int described = description && description[0];
    snprintf(r.text, sizeof r.text, "%s: parameter %s = %s is out of range: valid range %s%s%s%s", name, name,
             shortest(x).text, range, described ? " (" : "", described ? description : "", described ? ")" : "");
    return r;
}
