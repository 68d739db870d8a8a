/* A native FMU's model file and its variables. One runtime binary serves every native FMU, a
 * mechanism's or a component's: what an FMU adds is data, written by `crankfmu fmu --native` into
 * its resources/ (fmi/native/model_file.py) and read here when an instance is made (crank_model_file.c):
 * its kind, identifier, GUID, start time and the table of every variable (name, kind, start, range,
 * unit, description); a mechanism's counts, causality and compiled program
 * (dynamics/program_scenario.py) besides.
 *
 * The file: 16 bytes of magic ("crankfmu model\0\0"), the format version (uint32, little-endian),
 * its kind (uint32: CM_MODEL_...), the payload's size (uint64), the payload's SHA-256 (32 bytes),
 * then the payload (fmi/native/model_file.py writes it, in the order crank_model_file.c reads it). A
 * missing, truncated or altered file, or one of another format version, is refused at
 * instantiation with a message naming the file. */
#ifndef CRANK_VARIABLES_H
#define CRANK_VARIABLES_H

#include <stddef.h>

#include "crank_kernel.h"
#include "crank_mechanism.h"

#define CM_MODEL_FILE "crankfmu-model.bin"      /* its name in resources/ */
#define CM_MODEL_MAGIC "crankfmu model\0\0"
#define CM_MODEL_FORMAT 5
/* what the file's model is: a mechanism (crank_model.c), or a component (component_model.c): the
 * drive (torque out, speed in), the drive in speed causality (it carries the rotor), the die
 * cushion, the rod string, the elastic shaft */
enum { CM_MODEL_MECHANISM = 1, CM_MODEL_DRIVE, CM_MODEL_DRIVE_SPEED, CM_MODEL_CUSHION, CM_MODEL_ROD_STRING,
       CM_MODEL_SHAFT, CM_MODEL_KINDS };
/* what an FMU state holds at most: a file with more variables or ports is refused (its build too) */
#define CM_MAX_VARIABLES 1024
#define CM_MAX_INPUTS (1 + CK_MAX_PORTS)

enum { KIND_OUTPUT, KIND_INPUT, KIND_TUNABLE, KIND_FIXED, KIND_QUANTITY, KIND_DERIVATIVE, KIND_REACTION, KIND_FRICTION,
       KIND_COUNT };

typedef struct {
    const char* name;
    int kind;
    double start;
    int has_min, min_inclusive, has_max, max_inclusive;
    double min, max;
    const char* range;     /* the valid range as the refusal message states it */
    const char* unit;
    const char* description;
} Variable;

/* the output row's places (crank_kernel.h: phi1, omega1, W_motor, W_load, W_ext, epsilon1, M_motor,
 * M_load, J_red, tau_e; the native package's ROW_FIELDS) */
enum { ROW_PHI1, ROW_OMEGA1, ROW_W_MOTOR, ROW_W_LOAD, ROW_W_EXT, ROW_EPSILON1, ROW_M_MOTOR, ROW_M_LOAD, ROW_J_RED,
       ROW_TAU_E };
/* the joints' friction's outputs (dynamics.friction.friction_outputs' order), after the reactions:
 * M_friction, W_friction, then each declared joint's friction and its power */
enum { FRICTION_M = 0, FRICTION_W = 1, FRICTION_JOINTS = 2 };

/* A model as the file gives it. A component's variables are its data file's, in the Python FMU's
 * order (its model finds those it needs by name: component_models.c). A mechanism's value
 * references, in the order of the variables' table: the outputs first (n_outputs), then the crank's input (vr_crank_input: tau_ext, or omega1 in
 * speed causality), the tunables (fmi/native/model.py TUNABLE's order, or SPEED_TUNABLE's), the fixed
 * parameters (n_fixed), the scenario's [[outputs]] and its ports' outputs (n_quantities), the
 * derivatives of the Model Exchange states (phi1, omega1, W_motor, W_load, W_ext: the kernel's y;
 * none in speed causality), the ports' inputs (n_ports), the joint reactions (n_reactions) and, where
 * the program declares joint friction, its outputs (n_friction_outputs: 2 + 2 per joint). The Model
 * Exchange states (n_states) are the kernel's y: W_friction too where there is friction.
 *
 * Torque causality: the input tau_ext, the motor line, Co-Simulation and Model Exchange. Speed
 * causality: the input omega1, the outputs tau_drive and W_drive in the output row's M_motor and
 * W_motor places (ck_speed_*), Co-Simulation only: tau_drive needs omega1's derivative, which a
 * Model Exchange host has no call to pass. */
typedef struct {
    /* every kind's: what the model is, its identifier and GUID, its variables */
    int kind;
    const char *identifier, *guid;
    double default_start_time;
    int n_variables;
    const Variable* variables;
    /* a mechanism's */
    const char *mechanism_name, *mechanism_branch;
    int causality_speed, cycle_turns;
    int n_outputs, n_fixed, n_quantities, n_ports, n_reactions, reaction_terms, n_quantity_coordinates;
    int table_functions, table_sliders, vr_e_kin;
    double table_tolerance, reaction_tolerance;
    const int* output_row;          /* each output's place in the output row (-1: E_kin, from J_red and omega1) */
    /* the [[outputs]]: quantity k is order quantity_order[k] (0 position, 1 velocity, 2
     * acceleration) of coordinate quantity_coordinate[k]; the C model's [[outputs]] table holds
     * coordinate c's q - winding phi1, q' and q'' (dynamics/tabulated.py, QuantityTable). The joint
     * reactions: reaction k is sum_j reaction_terms weights (ck_reaction_weights) times the
     * reactions table's cubics k reaction_terms + j (ReactionTable) */
    const int *quantity_coordinate, *quantity_order;
    const int *column_powers;       /* each switched column's power of omega1 (CkTables.powers) */
    /* the scenario compiled for the C mechanism model, and each of its parameters' value reference
     * (-1: a parameter the FMU does not declare, at program_parameter_value), name; the names of
     * its checks and unknowns; the geometry parameters a refused assembly names, and the
     * parameters its tables depend on (the others, the motor line for one, do not) */
    mm_program program;
    int n_program_parameters;
    const int* program_parameter_vr;
    const double* program_parameter_value;
    const char* const* program_parameter_name;
    int n_check_names, n_geometry_parameters, n_table_parameters, n_unknown_names;
    const char* const* check_names;
    const int *geometry_parameters, *table_parameters;
    const char* const* unknown_names;
    /* the value references that follow from the counts */
    int vr_crank_input, vr_first_fixed, vr_first_quantity, vr_first_derivative, vr_first_port, vr_first_reaction;
    int vr_first_friction, n_friction_outputs;
    int n_derivatives, n_inputs, n_states;
    int vr_a, vr_b, vr_a_low, vr_b_low, vr_omega_switch, vr_j_flywheel, vr_phi1_start, vr_omega1_start, vr_rtol;
    /* what md_free releases */
    void** blocks;
    int n_blocks, blocks_size;
} ModelData;

/* The model file in the resources a host gave (fmi2's fmuResourceLocation, a file: URI, when
 * is_uri; fmi3's resourcePath, a path), read and checked: NULL with the reason (naming the file)
 * in why. md_free releases it. */
ModelData* md_load(const char* resources, int is_uri, char* why, size_t why_size);
/* the same from bytes (the fuzzer's), ``file`` naming them in messages */
ModelData* md_parse(const unsigned char* bytes, size_t size, const char* file, char* why, size_t why_size);
void md_free(ModelData* d);

#endif
