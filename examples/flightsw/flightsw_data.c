/*
 * Storage of every flight-software directory declared in this folder's
 * headers. Real flight software defines its directories in one translation
 * unit like this, and the generated catalogue only refers to them by name, so
 * an application links this file (or its own) and binds what it hosts.
 *
 * Initial values are the primary flight computer's (rmax1ob1) defaults; the
 * entity table is the paper's HITL configuration (Table 2).
 */
#include "actuators.h"
#include "datalink.h"
#include "entities.h"
#include "gps.h"
#include "health.h"
#include "imu.h"
#include "navfilter.h"
#include "nmea_gps.h"
#include "onboard.h"
#include "pubsub.h"
#include "sensors.h"
#include "sim.h"
#include "traffic.h"
#include "ubx_gps.h"
#include "waypoints.h"

/* Georgia Tech's flight-test range datum (McKenna MOUT site, Fort Benning). */
#define RANGE_DATUM                                                                                                    \
    { .latitudeDeg = 32.3738, .longitudeDeg = -84.9664, .altitudeMsl = 120.0f, .magneticVariationDeg = -3.8f }

onboardSet_t onboardSet = {
    .computer = COMPUTER_RMAX1OB1,
    .mode = MODE_STANDBY,
    .switches = { .enableDatalink2 = 1, .enableRelayPort = 1, .logLevel = 2 },
    .datum = RANGE_DATUM,
    .softwareVersion = 0x0207,
    .mainLoopRateHz = 100.0f,
    .onGround = 1,
    .vehicleName = "GTMax",
    .buildDescription = "rmax1ob1 flight build",
};
onboardSet_t onboard2Set = {
    .computer = COMPUTER_RMAX1OB2,
    .switches = { .enableVision = 1, .logLevel = 1 },
    .datum = RANGE_DATUM,
    .softwareVersion = 0x0207,
    .mainLoopRateHz = 50.0f,
    .onGround = 1,
    .vehicleName = "GTMax",
};
onboardSet_t fcsSet = {
    .computer = COMPUTER_FCS20,
    /* Same executable as rmax1ob1; the second datalink does not exist here. */
    .switches = { .enableDatalink2 = 0, .logLevel = 1 },
    .datum = RANGE_DATUM,
    .softwareVersion = 0x0207,
    .mainLoopRateHz = 50.0f,
    .onGround = 1,
    .vehicleName = "GTMax",
};
onboardTiming_t onboardTiming;
onboardTiming_t onboard2Timing;
onboardTiming_t fcsTiming;

gpsRaw_t gpsRaw;
nmeaGps_t gpsNmea;
ubxGps_t gpsUbx;
ubxCfg_t gpsUbxCfg;
gpsOut_t gpsOut;
gpsOut_t gpsSolution;
gpsOut_t gpsOutBackup;
gpsChannel_t gpsChannelPrimary[GPS_CHANNELS];
gpsChannel_t gpsChannelBackup[GPS_CHANNELS];
gpsEphemeris_t gpsEphemeris[GPS_MAX_PRN];

imuRaw_t imuRaw;
imuCalibration_t imuCalibration = {
    .gyro = { .scale = { 1.0f, 1.0f, 1.0f }, .misalignment = { { 1.0f }, { 0.0f, 1.0f }, { 0.0f, 0.0f, 1.0f } } },
    .accel = { .scale = { 1.0f, 1.0f, 1.0f }, .misalignment = { { 1.0f }, { 0.0f, 1.0f }, { 0.0f, 0.0f, 1.0f } } },
    .temperatureRef = 25.0f,
};
imuTemperatureComp_t imuTemperatureComp[3];
imuOut_t imuOut;
imuOut_t imuOutPrimary;

navFilterState_t navFilterState = { .attitude = { .q0 = 1.0 }, .health = HEALTH_UNKNOWN };
navFilterState_t navFilterStateBackup = { .attitude = { .q0 = 1.0 }, .health = HEALTH_UNKNOWN };
navCovariance_t navCovariance;
navFilterConfig_t navFilterConfig = {
    .gpsPosNoise = 1.5f,
    .gpsVelNoise = 0.2f,
    .magNoise = 0.05f,
    .sonarNoise = 0.1f,
    .gpsLatencyMs = 60,
    .useSonar = 1,
    .useMagnetometer = 1,
};
navSensorResidual_t navSensorResidual[NAV_SENSOR_COUNT];

servoCommand_t servoCommand[SERVO_CHANNELS];
servoFeedback_t servoFeedback[SERVO_CHANNELS];
servoCalibration_t servoCalibration[SERVO_CHANNELS] = {
    { 1000, 1500, 2000, 1, 0, "lat cyclic" },  { 1000, 1500, 2000, 1, 0, "lon cyclic" },
    { 1000, 1500, 2000, -1, 0, "collective" }, { 1000, 1500, 2000, 1, 0, "tail rotor" },
    { 1100, 1100, 1900, 1, 1, "throttle" },    { 1000, 1500, 2000, 1, 0, "spare" },
    { 1000, 1500, 2000, 1, 0, "camera pan" },  { 1000, 1500, 2000, 1, 0, "camera tilt" },
};
swashplateMix_t swashplateMix;
tailRotor_t tailRotor;
throttleGovernor_t throttleGovernor;
actuatorOut_t actuatorOut;
actuatorOut_t actuatorOutBackup;

datalinkPort_t onboardPortDatalink1 = { .kind = PORT_SERIAL, .baudRate = 115200, .enabled = 1, .deviceName = "/dev/ttyS1" };
datalinkPort_t onboardPortDatalink2 = { .kind = PORT_UDP, .udpPort = 2002, .enabled = 1, .deviceName = "wlan0" };
datalinkPort_t onboardPortIPC = { .kind = PORT_UDP, .udpPort = 2010, .enabled = 1, .deviceName = "eth0" };
datalinkPort_t onboardPortRelay = { .kind = PORT_SERIAL, .baudRate = 57600, .enabled = 1, .deviceName = "/dev/ttyS2" };
datalinkPort_t onboard2PortIPC = { .kind = PORT_UDP, .udpPort = 2010, .enabled = 1, .deviceName = "eth0" };
datalinkPort_t gcsPortDatalink1 = { .kind = PORT_SERIAL, .baudRate = 115200, .enabled = 1, .deviceName = "COM3" };
datalinkPort_t gcsPortDatalink2 = { .kind = PORT_UDP, .udpPort = 2002, .enabled = 1, .deviceName = "wlan0" };
datalinkRxQueue_t datalinkRxQueue;

/* Entity table of rmax1ob1 (paper Table 2): masks are one hex digit per link. */
systemEntity_t systemEntity0 = {
    .name = "rmax1ob1",
    .kind = ENTITY_PRIMARY_FCS,
    .local = 1,
    .numLinks = 4,
    .linkName = { "onboardPortDatalink1", "onboardPortDatalink2", "onboardPortIPC", "onboardPortRelay" },
    .linkToEntity = { 0x00000000, 0x00000011, 0x00000100, 0x00001000 },
};
systemEntity_t systemEntity1 = { .name = "gcs1", .kind = ENTITY_GCS };
systemEntity_t systemEntity2 = { .name = "rmax1ob2", .kind = ENTITY_SECONDARY_FCS };
systemEntity_t systemEntity3 = { .name = "fcs20", .kind = ENTITY_BACKUP_FCS };
systemEntity_t systemEntity4;
systemEntity_t systemEntity5;
systemEntity_t systemEntity6;
systemEntity_t systemEntity7;

pubsubEntity_t pubsubRmax1ob1 = { .entityID = "rmax1ob1" };
pubsubEntity_t pubsubRmax1ob2 = { .entityID = "rmax1ob2" };
pubsubEntity_t pubsubFcs20 = { .entityID = "fcs20" };
pubsubEntity_t pubsubGcs1 = { .entityID = "gcs1" };
pubsubAdminRow_t pubsubAdminTable[PUBSUB_ADMIN_ROWS];

waypoint_t waypointPlan[WAYPOINT_PLAN_SIZE];
waypoint_t rallyPoint[RALLY_POINTS];
waypointPlanStatus_t waypointPlanStatus;
loiterPattern_t loiterPattern[LOITER_PATTERNS];
waypoint_t gcsMissionRmax1[GCS_MISSION_SIZE];
waypoint_t gcsMissionRmax2[GCS_MISSION_SIZE];
geofenceVertex_t geofenceVertex[GEOFENCE_VERTICES];

trafficTrack_t trafficRmax1[TRAFFIC_TRACKS];
trafficTrack_t trafficRmax2[TRAFFIC_TRACKS];
trafficTrack_t trafficGTMax[TRAFFIC_TRACKS];
trafficSummary_t trafficSummary;

magnetometer_t magnetometer;
altimeter_t sonarAltimeter;
altimeter_t radarAltimeter;
airData_t airData;
engineSensors_t engineSensors;
batteryCell_t batteryCell[BATTERY_PACKS][CELLS_PER_PACK];
thermocouple_t thermocouple[THERMO_BOARDS][THERMO_CHANNELS];
cameraTrack_t cameraTrack[CAMERAS][TRACKS_PER_CAMERA];

healthMonitor_t healthMonitor = { .overall = HEALTH_UNKNOWN };
taskHealth_t taskHealth[HEALTH_TASKS];
cpuLoad_t cpuLoad[COMPUTERS] = {
    { .computer = COMPUTER_RMAX1OB1 },
    { .computer = COMPUTER_RMAX1OB2 },
    { .computer = COMPUTER_FCS20 },
};
faultLogEntry_t faultLog[FAULT_LOG_SIZE];
watchdogStatus_t watchdogStatus = { .timeoutMs = 250 };

simVehicleState_t simVehicleState[SIM_VEHICLES];
simEnvironment_t simEnvironment = { .timeScale = 1.0, .randomSeed = 20050815u };
