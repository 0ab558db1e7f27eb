// A speed-optimised file: the build compiles it with flags of its own (compile_commands.json).
#include "flight/pid.h"

PG_REGISTER_ARRAY(pidProfile_t, MAX_PROFILE_COUNT, pidProfiles);
