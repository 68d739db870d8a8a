/* The mechanism model in C: any mechanism file's contours, points, links and loads, evaluated at
 * any parameter values and tabulated for the kernel.
 *
 * crankfmu compiles the data files once into a program (dynamics/program.py): an instruction list
 * of arithmetic on registers (the files' expressions: term coefficients, closed forms, masses,
 * loads, ports) and the tables of the contour terms. One evaluator runs every mechanism, so no
 * compiler is needed at run time: an FMU carries its program (a few kB) instead of its tables, and
 * tabulates when it initialises, at the parameter values the host set.
 *
 * What the program leaves to this file is the part no expression states: the Newton solve of the
 * contours with its continuation along the turn, the transfer functions (two linear solves with
 * the contour Jacobian), the assembly check, the searches for switch angles, and the tabulator
 * (Fourier series of the engine's samples, then Hermite cubics, each checked against the engine).
 * The Python contour engine (mechanisms/contour.py) is the independent reference; the tests
 * compare the two point by point.
 */
#ifndef CRANK_MECHANISM_H
#define CRANK_MECHANISM_H

/* the instruction set: each instruction is five ints (op, destination, a, b, c) */
enum mm_op {
    MM_LITERAL, MM_COPY, MM_ADD, MM_SUB, MM_MUL, MM_DIV, MM_POW, MM_NEG,
    MM_SIN, MM_COS, MM_TAN, MM_ASIN, MM_ACOS, MM_ATAN, MM_ATAN2, MM_SQRT, MM_HYPOT, MM_EXP, MM_LOG,
    MM_ABS, MM_SIGN, MM_MIN, MM_MAX, MM_RADIANS, MM_DEGREES,
    MM_IF_POSITIVE,   /* a > 0 ? b : c */
    MM_IF_NEGATIVE,   /* a < 0 ? b : c */
    MM_NOT_ABOVE,     /* a <= b ? 1 : 0 */
    MM_TANH, MM_SINH, MM_COSH,
    MM_N_OPS
};

/* the program's sections: code ranges run at binding (SETUP), per crank angle (CLOSED: the
 * closed-form positions; ROWS: the table's functions; VALUES: the switched loads' values for a
 * direction of the crank), per crank speed at each step (LAWS: the general laws of the speed,
 * dynamics/speed_laws.py), and the searches' quantities after them */
enum { MM_SETUP, MM_CLOSED, MM_ROWS, MM_VALUES, MM_OUTPUTS, MM_REACTIONS, MM_LAWS, MM_FIRST_SEARCH };
/* the tables a model gives: the reduced model's (J, 0.5 J', the loads, the ports' transfer
 * functions), the [[outputs]] and ports' coordinates (q - winding phi1, q', q'' each), the joint
 * reactions' terms (component-major, dynamics.reaction_table.REACTION_TERMS then the columns, the ports
 * and each active joint friction at value 1), and the joints' friction (friction_table.FrictionTable's
 * rows, function-major: each active friction's relative rate, then each one's reaction components'
 * terms as the reactions') */
enum { MM_TABLE_REDUCED, MM_TABLE_QUANTITIES, MM_TABLE_REACTIONS, MM_TABLE_FRICTION };

/* a search over the turn (its record: kind, section, aux section, a, b, c, d) */
enum mm_search {
    MM_ROCKER,        /* the section's value is a rocker's rate: its one rise -> register a, fall -> b */
    MM_REVERSALS,     /* the value is a rate: where it vanishes are switch angles; with a >= 0 the aux
                         section's value there gives its smallest (-> a) and largest (-> b) */
    MM_BAND,          /* the value is a position with extremes in registers a, b: the switch angles
                         where it crosses a + f (b - a) and b - f (b - a), f = the values of c and d */
    MM_ZEROS,         /* the value is a kink's argument (max, min, abs, sign in a load): where it
                         crosses zero are switch angles; none is allowed (the kink keeps one side) */
    MM_FRICTION_RATE  /* the value is joint friction a's relative rate (dynamics.friction): where it
                         crosses zero are switch angles, none where the friction is not active or its
                         joint's links never move relative to each other */
};
#define MM_SEARCH_FIELDS 7
#define MM_TERM_FIELDS 6     /* chain, coefficient register, length column, angle column, offset register,
                                its distinct angle */

/* errors: what went wrong, where (mm_model.error_angle, rad), and which (error_index) */
enum mm_error {
    MM_OK = 0,
    MM_NO_SOLUTION = -1,      /* the contour equations have no real solution (a closed form's NaN) */
    MM_SINGULAR = -2,         /* the contour Jacobian is singular (dead point) */
    MM_NO_CONVERGENCE = -3,   /* Newton's method did not converge */
    MM_GUESS = -4,            /* ... from the file's guess */
    MM_LOST = -5,             /* the continuation lost the assembly */
    MM_BRANCH = -6,           /* after one turn an unknown does not return (index: the unknown) */
    MM_DEAD_POINT = -7,       /* the conditioning changes sign */
    MM_LOCKS = -8,            /* the conditioning falls below its bound (error_value) */
    MM_CLOSED_FORM = -9,      /* the closed form does not satisfy the contours (error_value: residual m) */
    MM_CHECK = -10,           /* a value check failed (index: the check) */
    MM_NOT_ROCKER = -11,      /* a rocker search found other than one rise and one fall (index: search) */
    MM_NO_REVERSAL = -12,     /* a reversal search found none (index: search) */
    MM_NOT_TABULATED = -13,   /* neither the Fourier series nor 2^16 spline intervals reach the tolerance */
    MM_NO_MEMORY = -14,
    MM_TOO_MANY_SWITCHES = -15,
    MM_NOT_FINITE = -16,      /* a function of the table is not finite, or beyond 1e150 (index: its row) */
    MM_JUMPS = -17            /* a closed form's unknown jumps along the turn (index: the unknown's column,
                               * value: the jump, rad or m; angle: where) */
};

typedef struct {
    int n_registers;
    int n_code;
    const int *code;                 /* n_code x 5 */
    const double *literals;
    int n_sections;
    const int *sections;             /* n_sections x 2: first instruction, end */
    /* the contours and points */
    int n_q;                         /* 1 + the unknowns: q = (phi1, unknowns...) */
    int n_contours;                  /* contour chains (2 rows each: n_q - 1 = 2 n_contours) */
    int n_chains;                    /* contours, then points */
    int n_terms;
    const int *terms;                /* n_terms x MM_TERM_FIELDS */
    int n_angles;
    const int *angles;               /* n_angles x 2: the distinct angles' column (-1: none) and offset register */
    const int *chain_constants;      /* n_chains x 2: registers of the constant x, y (-1: zero) */
    const int *angle_column;         /* n_q: 1 where q is an angle */
    int closed_form;                 /* 1: the CLOSED section gives the unknowns */
    int guess;                       /* first of n_q registers: the guess's phi1 and unknowns */
    /* per-angle registers */
    int phi1;                        /* phi1's register; q_j, q_j', q_j'' (j >= 1) follow at kinematics */
    int kinematics;                  /* first of 3 (n_q - 1) unknown registers, then 6 per point */
    int n_points;
    int omega1;                      /* the VALUES section's crank direction (+1 or -1) */
    /* the table */
    int n_rows;
    const int *rows;                 /* registers ROWS leaves each function in */
    int n_columns;
    const int *columns;              /* registers VALUES leaves each switched column's value in */
    int n_searches;
    const int *searches;             /* n_searches x MM_SEARCH_FIELDS */
    int n_checks;
    const int *checks;               /* registers that must be finite and >= 0 after SETUP */
    double min_conditioning;
    /* the [[outputs]] and ports' coordinates: q, q', q'' registers and whether it is an angle */
    int n_coordinates;
    const int *coordinates;          /* n_coordinates x 4 */
    /* the joint reactions (dynamics/reactions.py): links (centre point, mass, inertia, q', q''
     * registers), the crank's index, joints (prismatic?, point, first link, second link (-1: the
     * ground), axis register), each term's inertia factors (epsilon1, omega1^2) and the loads each
     * term applies (term, link, point or -1, fx, fy, moment registers or -1), REACTIONS computing them */
    int n_links;
    const int *links;
    int crank;
    int n_joints;
    const int *joints;
    int n_terms_reaction;
    const int *term_inertia;
    int n_applied;
    const int *applied;
    /* crank turns of the machine's cycle: the reduced model's and the reactions' tables are
     * periodic over it (the loads repeat over it), the [[outputs]]' over one turn */
    int cycle_turns;
    /* the general laws of the speed: LAWS reads the crank speed from register law_speed and leaves
     * each switched column's law in laws[column] (-1: the column has none) */
    int law_speed;
    const int *laws;                 /* n_columns */
    /* the joints' friction (dynamics/friction.py): each declared one's joint, the register of its
     * coefficient c (mu r or mu, SETUP's; 0: the friction is not active at these values) and of its
     * relative rate (REACTIONS'). The reaction table's last n_frictions terms are their unit loads */
    int n_frictions;
    const int *frictions;            /* n_frictions x 3 */
} mm_program;

#define MM_TURN_POINTS 720
#define MM_SCAN_POINTS 1440
#define MM_MAX_SWITCHES 64
#define MM_MAX_FRICTIONS 16

typedef struct {
    const mm_program *program;
    double *registers;
    double length_scale;
    /* the turn table: positions every 2 pi / 720 from its start, angles continuous; winding */
    double turn_start;
    double *turn;                    /* (MM_TURN_POINTS + 1) x n_q */
    double *winding;                 /* n_q */
    int have_turn;
    /* where the checks failed */
    double error_angle;
    double error_value;
    int error_index;
    /* the switched loads' schedule */
    int n_switches;
    double switches[MM_MAX_SWITCHES];
    double *forces;                  /* max(n_switches, 1) x 2 x n_columns */
    double worst_conditioning, worst_angle;
    double *scan;                    /* the kinematics at every other scan angle, for the searches */
    double *coordinate_winding;      /* whole turns per crank turn of each coordinate */
    int *reaction_kept;              /* components x terms: 0 where a term is zero to round-off */
    int have_quantity_winding, have_reaction_mask;
    /* a table that cannot be built (MM_NOT_TABULATED): the function's row is error_index, its
     * checked error error_value, where it changes fastest error_angle (rad), by error_step
     * between two of the last samples; error_jumps: that step is over 1e3 times the median's
     * (a discontinuity in phi1, not a dead point) */
    double error_step;
    int error_jumps;
    /* the LAWS section ran at the speed in its register (mm_law runs it once per speed, not once
     * per column: its registers are its own, and binding clears this) */
    int law_ready;
    /* the joints' friction at these values (mm_prepare): the active ones (c > 0), their declared
     * index; whether each one's links move relative to each other (its rate's peak over the turn,
     * beyond 1e-12 of the largest, at least 1: a rate that is round-off has no sign); each one's
     * sign on each switch interval forward (max(n_switches, 1) x n_active); the friction table's
     * terms kept (as reaction_kept) */
    int n_active;
    int active[MM_MAX_FRICTIONS];
    int moving[MM_MAX_FRICTIONS];
    double rate_peak[MM_MAX_FRICTIONS];
    double friction_signs[MM_MAX_SWITCHES * MM_MAX_FRICTIONS];
    int *friction_kept;
    int have_friction_mask;
} mm_model;

/* a model of the program at the parameter values (its first registers): SETUP run, the checks,
 * the turn table; MM_OK or an error. mm_free releases it (also after an error). */
int mm_bind(mm_model *model, const mm_program *program, const double *parameters, int n_parameters);
void mm_free(mm_model *model);
/* the kinematics at phi1 into the model's registers (q, q', q'' and the points'), then ROWS */
int mm_evaluate(mm_model *model, double phi1);
/* the assembly check over the turn (mm_check), then the searches and the switch schedule */
int mm_check(mm_model *model, int coarse);
int mm_prepare(mm_model *model);
/* crank turns a table's functions repeat over: the program's cycle_turns (QUANTITIES: 1) */
int mm_table_turns(const mm_model *model, int table);
/* the functions of a table (MM_TABLE_...) at n angles: rows x n, row-major */
int mm_rows(const mm_model *model, int table);
int mm_engine(mm_model *model, int table, const double *phi1, int n, double *out);
/* a table: periodic cubics (rows, m, 4) on m intervals of its period (mm_table_turns turns) to
 * tolerance, by the Fourier series of the engine's
 * samples, else by the periodic cubic spline of up to 2^16 samples (kept where its error is within
 * 1e-8 when 2^16 do not reach the tolerance); *m_out its intervals, *error the checked bound,
 * *n_series the series' samples (0: the spline's). The cubics are malloc'd (*cubics). */
int mm_tabulate(mm_model *model, int table, double tolerance, double **cubics, int *m_out, double *error,
                int *n_series);

/* free the cubics mm_tabulate gave */
void mm_release(double *cubics);

/* the reaction table's terms at these values: the program's less its inactive frictions' */
int mm_reaction_terms(const mm_model *model);
/* a friction table's reaction components (sum over the active frictions: 2 a pin's, 1 a slide's) */
int mm_friction_components(const mm_model *model);

/* the law of the speed of switched column ``column`` at omega (the kernel's CkLaw, its context a
 * bound mm_model): the LAWS section run at that speed; NaN where the column has none */
double mm_law(const void *model, int column, double omega);

#endif
