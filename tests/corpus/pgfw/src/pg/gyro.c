#include "pg/gyro.h"

PG_REGISTER(gyroConfig_t, gyroConfig);
