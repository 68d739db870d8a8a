/* The FMU states the native shells hand out (fmi2GetFMUstate, fmi3GetFMUState and the
 * deserialisers): each starts with a mark, so a shell knows a state of its own from anything else a
 * host passes, and a host's slip cannot crash it.
 *
 * The slip seen in a real master: fmusim (modelica/Reference-FMUs 0.0.39) calls
 * fmi2FreeFMUstate(c, state) and fmi3FreeFMUState(instance, state) with the state itself where the
 * standard passes its address, after saving a state to a file (--final-fmu-state-file) and after
 * restoring one (--initial-fmu-state-file). Freeing what that pointer points to crashed the host
 * (SIGSEGV). A state's first bytes are its mark and a host variable's are a pointer, which is never
 * the mark (its top bit set: no user-space address), so reading the first 8 bytes tells the two
 * apart; both reads are of memory the host gave.
 *
 * Header only: the FMI 2.0 and 3.0 shells include it (through fmu_model.h). */
#ifndef FMU_STATES_H
#define FMU_STATES_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define FMU_STATE_MARK 0xC3A5F00DFEEDC0DEULL

/* the mark every state object starts with (the first member of the shells' Snapshot) */
typedef uint64_t FmuStateMark;

static inline void fmu_state_mark(void* state) { FmuStateMark m = FMU_STATE_MARK; memcpy(state, &m, sizeof m); }

static inline int fmu_state_is_ours(const void* state)
{
    FmuStateMark m = 0;
    if (!state) return 0;
    memcpy(&m, state, sizeof m);
    return m == FMU_STATE_MARK;
}

/* The state a host's free call names: the one at *given as the standard says, or given itself
 * where the host passed the state instead of its address (*slipped = 1). NULL when neither is a
 * state of ours (nothing to free: a second free, or not a state). */
static inline void* fmu_state_to_free(void** given, int* slipped)
{
    *slipped = 0;
    if (!given) return NULL;
    if (fmu_state_is_ours(given)) {
        *slipped = 1;
        return (void*)given;
    }
    return fmu_state_is_ours(*given) ? *given : NULL;
}

/* before a state's memory is released: a later free of the same pointer finds no mark */
static inline void fmu_state_unmark(void* state) { memset(state, 0, sizeof(FmuStateMark)); }

/* The six FMU-state calls of an FMI shell, written once for both versions (which name them apart):
 * each a forward to the one model API (fmu_model.h's fm_state_...), which checks that a state is
 * one of this FMU's. The shell defines FORWARD(instance, model call) and MODEL(instance). */
#define FMU_STATE_CALLS(Status, Instance, State, Byte, GET, SET, FREE, SIZE, SERIALIZE, DESERIALIZE)             \
    Status GET(Instance c, State* s) { return FORWARD(c, fm_state_save(MODEL(c), #GET, s)); }                     \
    Status SET(Instance c, State s) { return FORWARD(c, fm_state_restore(MODEL(c), #SET, s)); }                   \
    Status FREE(Instance c, State* s) { return FORWARD(c, fm_state_release(MODEL(c), #FREE, s)); }                \
    Status SIZE(Instance c, State s, size_t* n) { return FORWARD(c, fm_state_size(MODEL(c), #SIZE, s, n)); }      \
    Status SERIALIZE(Instance c, State s, Byte b[], size_t n)                                                     \
    {                                                                                                             \
        return FORWARD(c, fm_state_write(MODEL(c), #SERIALIZE, s, (unsigned char*)b, n));                         \
    }                                                                                                             \
    Status DESERIALIZE(Instance c, const Byte b[], size_t n, State* s)                                            \
    {                                                                                                             \
        return FORWARD(c, fm_state_read(MODEL(c), #DESERIALIZE, (const unsigned char*)b, n, s));                  \
    }

#endif
