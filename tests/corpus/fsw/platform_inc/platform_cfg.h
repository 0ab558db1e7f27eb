/* Platform limits; the build defines which CPU it is for (flags.txt). */
#ifndef PLATFORM_CFG_H
#define PLATFORM_CFG_H

#ifndef MISSION_CPU
#error "build with -DMISSION_CPU=<n> (see flags.txt)"
#endif

#define NAV_MAX_WAYPOINTS 16
#define HK_DUMP_WORDS 600
#define SC_RTS_WORDS 150

#endif
