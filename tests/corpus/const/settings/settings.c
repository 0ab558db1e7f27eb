#include "settings.h"

setting_t settings[SETTINGS_COUNT] = {
    {"gyro_lpf", VAR_UINT8, {0, 255}, {1, 0}, 1.0f, true, 90},
    {"pitch_p", VAR_INT16, {0, 200}, {0, 1}, 0.5f, true, 42},
    {"thr_mid", VAR_FLOAT, {0, 100}, {0, 0}, 0.01f, false, 50},
};
