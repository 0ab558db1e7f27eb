/* The housekeeping application. */
#include "hk_msg.h"

HK_HkTlm_t HK_HkTlm;
HK_MemDump_t HK_MemDump;
HK_Raw_u HK_Raw;
