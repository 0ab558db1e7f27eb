/* cffi cdef for runtime_c/include/ub/ub_motion.h: the simulated vehicles' flight model. */

#define UB_MOTION_MAX_WAYPOINTS ...

typedef enum ub_motion_kind { UB_MOTION_ORBIT, UB_MOTION_WAYPOINTS, UB_MOTION_STATIC, ... } ub_motion_kind_t;

typedef struct ub_motion { uint8_t kind; ...; } ub_motion_t;

typedef struct ub_motion_state {
    double north_m, east_m, up_m;
    double lat_deg, lon_deg, alt_msl_m;
    double vel_ned[3];
    double heading_rad;
    double rates[3];
    double specific_force[3];
    double attitude[4];
    ...;
} ub_motion_state_t;

void ub_motion_default(ub_motion_t *m);
int ub_motion_parse(const char *text, ub_motion_t *m, char *err, size_t err_cap);
void ub_motion_sample(const ub_motion_t *m, double t_s, ub_motion_state_t *out);
double ub_motion_distance(const ub_motion_state_t *a, const ub_motion_state_t *b);
