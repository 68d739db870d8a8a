/* A coverage-guided fuzzer (libFuzzer, clang -fsanitize=fuzzer,address,undefined) of a native
 * mechanism FMU's FMI 2.0 API: compiled together with the FMU's own sources/ (its shell, its model
 * and the kernel), it reads each input as a host's life: Co-Simulation or Model Exchange, logging
 * on or off, then up to 64 calls in any order with parameter values and step sizes drawn from the
 * input (finite, huge, negative, NaN, infinite), FMU states got, set, serialized and corrupted.
 * One input in four is instead the FMU's model file (resources/crankfmu-model.bin) corrupted: a
 * byte changed, the file cut short or grown, as it lies (the digest must refuse it at instantiation,
 * with a message) or with its digest made to match (the reader must refuse it or read it whole,
 * never step outside it).
 *
 * What every call is held to (a violation traps, which libFuzzer reports with the input):
 * - its status is fmi2OK or fmi2Error (never fmi2Discard or fmi2Fatal, never a crash: ASan and
 *   UBSan watch every access and every operation);
 * - an fmi2Error comes with a logStatusError message, whatever loggingOn is;
 * - after an accepted fmi2DoStep, the contract's outputs read back fmi2OK and finite.
 * A hang is caught by libFuzzer's -timeout.
 *
 *   tests/test_fmi_fuzzer.py builds and runs it briefly (make test); make soak runs it long.
 *   The corpus it starts from: tests/fuzz/corpus/. FUZZ_RESOURCES: the FMU's resources folder. */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "crank_variables.h"
#include "sha256.h"
#include "fmi2Functions.h"

static int errors_logged;
/* the FMU's model file, its resources' URI, and the model it holds (read once) */
static unsigned char* model_bytes;
static size_t model_size;
static char resources_uri[4200];
static const ModelData* model;

int LLVMFuzzerInitialize(int* argc, char*** argv)
{
    (void)argc, (void)argv;
    const char* folder = getenv("FUZZ_RESOURCES");
    char why[1024], path[4200];
    if (!folder || !(model = md_load(folder, 0, why, sizeof why))) {
        fprintf(stderr, "fmi2_fuzzer: FUZZ_RESOURCES must name the FMU's resources: %s\n", folder ? why : "unset");
        exit(2);
    }
    snprintf(resources_uri, sizeof resources_uri, "file://%s", folder);
    snprintf(path, sizeof path, "%s/%s", folder, CM_MODEL_FILE);
    FILE* f = fopen(path, "rb");
    model_bytes = (unsigned char*)malloc(1 << 20);
    model_size = f ? fread(model_bytes, 1, 1 << 20, f) : 0;
    if (f) fclose(f);
    return 0;
}

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    (void)env, (void)name, (void)message;
    if (status == fmi2Error && category && strcmp(category, "logStatusError") == 0) errors_logged++;
}

typedef struct {
    const uint8_t* data;
    size_t size, at;
} Input;

static unsigned byte(Input* in) { return in->at < in->size ? in->data[in->at++] : 0; }

/* a value for a variable: special values, a scale of its start, or raw bits */
static double value(Input* in, double start)
{
    static const double SPECIAL[] = {0.0, -0.0, 1.0, -1.0, 1e300, -1e300, 1e-300, INFINITY, -INFINITY, NAN, 0.5, 2.0};
    unsigned kind = byte(in) % 4;
    if (kind == 0) return SPECIAL[byte(in) % (sizeof SPECIAL / sizeof SPECIAL[0])];
    if (kind == 1) return start * (0.25 + byte(in) / 64.0);
    if (kind == 2) return start + (double)(int)(byte(in) - 128);
    double x;
    uint64_t bits = 0;
    for (int k = 0; k < 8; k++) bits = (bits << 8) | byte(in);
    memcpy(&x, &bits, sizeof x);
    return x;
}

static double step_size(Input* in)
{
    static const double STEPS[] = {1e-3, 1e-2, 0.1, 0.5, 1e-9, 0.0, -1e-3, INFINITY, NAN, 2.0};
    return STEPS[byte(in) % (sizeof STEPS / sizeof STEPS[0])];
}

/* the call's status must be OK, or Error with a logged error message */
static void held(fmi2Status status, int logged_before)
{
    if (status == fmi2OK) return;
    if (status != fmi2Error) __builtin_trap();
    if (errors_logged == logged_before) __builtin_trap();
}

#define CALL(expr)                        \
    do {                                  \
        int before = errors_logged;       \
        fmi2Status s_ = (expr);           \
        held(s_, before);                 \
        last = s_;                        \
    } while (0)

/* the model file corrupted (header byte: which way): the reader refuses it with a message, or, its
 * digest made to match, reads it whole or refuses it; never a crash, a leak or a read outside it */
static void corrupt_model_file(Input* in, unsigned head)
{
    size_t size = model_size;
    unsigned char* bytes = (unsigned char*)malloc(model_size + 64);
    memcpy(bytes, model_bytes, model_size);
    unsigned how = (head >> 4) & 3;
    size_t at = ((size_t)byte(in) << 16 | (size_t)byte(in) << 8 | byte(in)) % model_size;
    if (how == 0) size = at;                                        /* cut short */
    else if (how == 1) memset(bytes + size, byte(in), 64), size += 1 + byte(in) % 63;   /* grown */
    else bytes[at] ^= (unsigned char)(1 + byte(in) % 255);          /* a byte changed */
    for (int k = 0; k < 8 && how == 3; k++) {                       /* more bytes, and the digest made to match */
        size_t more = ((size_t)byte(in) << 8 | byte(in)) % (model_size - 64);
        bytes[64 + more] = (unsigned char)byte(in);
    }
    if (how == 3) sha256(bytes + 64, size - 64, bytes + 32);
    char why[1024];
    why[0] = 0;
    ModelData* d = md_parse(bytes, size, "fuzzed", why, sizeof why);
    if (!d && strncmp(why, "the model file fuzzed ", 22) != 0) __builtin_trap();   /* refused, and says why */
    if (d && how != 3) __builtin_trap();                            /* as it lies: the digest refuses every change */
    md_free(d);
    free(bytes);
}

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    Input in = {data, size, 0};
    unsigned head = byte(&in);
    if ((head & 0xC) == 0xC) {
        corrupt_model_file(&in, head);
        return 0;
    }
    int me = !model->causality_speed && (head & 1);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("fuzz", me ? fmi2ModelExchange : fmi2CoSimulation, model->guid, resources_uri,
                                      &cb, fmi2False, (head >> 1) & 1);
    if (!c) __builtin_trap();
    fmi2FMUstate state = NULL;
    double t = 0.0;
    fmi2Status last = fmi2OK;
    for (int n = 0; n < 64 && in.at < in.size; n++) {
        unsigned op = byte(&in) % 16;
        fmi2ValueReference vr = (fmi2ValueReference)(byte(&in) % (model->n_variables + 2));
        switch (op) {
        case 0:
            CALL(fmi2SetupExperiment(c, fmi2False, 0.0, value(&in, 0.0), byte(&in) & 1, value(&in, 10.0)));
            break;
        case 1: CALL(fmi2EnterInitializationMode(c)); break;
        case 2: CALL(fmi2ExitInitializationMode(c)); break;
        case 3:
        case 4: {
            double x = value(&in, vr < model->n_variables ? model->variables[vr].start : 1.0);
            CALL(fmi2SetReal(c, &vr, 1, &x));
            break;
        }
        case 5: {
            double x;
            CALL(fmi2GetReal(c, &vr, 1, &x));
            break;
        }
        case 6:
            if (me) {
                double x[CK_N_Y];
                for (int j = 0; j < model->n_states; j++) x[j] = value(&in, 1.0);
                CALL(fmi2SetContinuousStates(c, x, (size_t)model->n_states));
            } else {
                double h = step_size(&in);
                CALL(fmi2DoStep(c, t, h, fmi2True));
                if (last == fmi2OK) {
                    t += h;
                    double out[64];
                    fmi2ValueReference vrs[64];
                    for (int j = 0; j < model->n_outputs; j++) vrs[j] = (fmi2ValueReference)j;
                    if (fmi2GetReal(c, vrs, model->n_outputs, out) != fmi2OK) __builtin_trap();
                    for (int j = 0; j < model->n_outputs; j++)
                        if (!isfinite(out[j])) __builtin_trap();
                }
            }
            break;
        case 7: CALL(fmi2Reset(c)); t = 0.0; break;
        case 8: CALL(fmi2GetFMUstate(c, &state)); break;
        case 9:
            if (state) CALL(fmi2SetFMUstate(c, state));
            break;
        case 10:
            if (state) {
                size_t bytes = 0;
                CALL(fmi2SerializedFMUstateSize(c, state, &bytes));
                if (last == fmi2OK && bytes > 0 && bytes < (1u << 24)) {
                    fmi2Byte* buffer = (fmi2Byte*)malloc(bytes);
                    CALL(fmi2SerializeFMUstate(c, state, buffer, bytes));
                    size_t cut = byte(&in) & 1 ? bytes : bytes / 2;        /* whole, or corrupted */
                    if (cut < bytes) buffer[cut / 2] ^= (fmi2Byte)0x5a;
                    fmi2FMUstate back = NULL;
                    CALL(fmi2DeSerializeFMUstate(c, buffer, cut, &back));
                    if (back) {
                        CALL(fmi2SetFMUstate(c, back));
                        fmi2FreeFMUstate(c, &back);
                    }
                    free(buffer);
                }
            }
            break;
        case 11:
            if (me) {
                double z[CK_N_SLOTS];
                CALL(fmi2GetEventIndicators(c, z, CK_N_SLOTS));
            } else {
                double x = value(&in, 1.0);
                fmi2Integer order = (fmi2Integer)(byte(&in) % 3);
                fmi2ValueReference input = model->vr_crank_input;
                CALL(fmi2SetRealInputDerivatives(c, &input, 1, &order, &x));
            }
            break;
        case 12:
            if (me) {
                double dx[CK_N_Y];
                CALL(fmi2GetDerivatives(c, dx, (size_t)model->n_states));
            } else {
                CALL(fmi2Terminate(c));
            }
            break;
        case 13:
            if (me) {
                fmi2EventInfo info;
                CALL(fmi2EnterEventMode(c));
                CALL(fmi2NewDiscreteStates(c, &info));
                CALL(fmi2EnterContinuousTimeMode(c));
            } else {
                double x;
                CALL(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &x));
            }
            break;
        case 14:
            if (me) CALL(fmi2SetTime(c, value(&in, t)));
            else CALL(fmi2DoStep(c, value(&in, t), step_size(&in), fmi2True));   /* a wrong communication point */
            break;
        default: {
            fmi2Integer i = 0;
            CALL(fmi2GetInteger(c, &vr, 1, &i));
            break;
        }
        }
    }
    if (state) fmi2FreeFMUstate(c, &state);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
    return 0;
}
