#pragma once
#define CONFIGURATION_H_VERSION 02010200
//#define COREXY
/**
 * #define DEFAULT_MAX_FEEDRATE { 1, 1, 1, 1 }   (inside a comment: not read)
 */
#define DEFAULT_AXIS_STEPS_PER_UNIT   { 80, 80, 400, 93 }
#define DEFAULT_MAX_FEEDRATE          { 500, 500, 5, 25 }
#define DEFAULT_MAX_ACCELERATION      { 500, 500, 100, 5000 }
#define DEFAULT_ACCELERATION          500    // X, Y, Z and E acceleration for printing moves
#define DEFAULT_RETRACT_ACCELERATION  500    // E acceleration for retracts
#define DEFAULT_TRAVEL_ACCELERATION   (DEFAULT_ACCELERATION * 2)
//#define CLASSIC_JERK
#if ENABLED(CLASSIC_JERK)
  #define DEFAULT_XJERK 10.0
  #define DEFAULT_YJERK 10.0
  #define DEFAULT_ZJERK  0.3
#endif
#define DEFAULT_EJERK    5.0  // May be used by Linear Advance
#if DISABLED(CLASSIC_JERK)
  #define JUNCTION_DEVIATION_MM 0.08 // (mm) Distance from real junction edge
#endif
//#define S_CURVE_ACCELERATION
#define DEFAULT_NOMINAL_FILAMENT_DIA 1.75

---
#pragma once
#define DEFAULT_MINSEGMENTTIME        20000   // (us)
#define DEFAULT_MINIMUMFEEDRATE       0.0     // (mm/s)
#define DEFAULT_MINTRAVELFEEDRATE     0.0
#define BLOCK_BUFFER_SIZE 16
#define ARC_SUPPORT
#if ENABLED(ARC_SUPPORT)
  #define MIN_ARC_SEGMENT_MM      0.1
  #define MAX_ARC_SEGMENT_MM      1.0
  #define MIN_CIRCLE_SEGMENTS    72
  //#define ARC_SEGMENTS_PER_SEC 50
#endif
