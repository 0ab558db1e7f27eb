# Fails when the bridge library defines MAVLink's channel state (m_mavlink_status / m_mavlink_buffer,
# the static arrays behind mavlink_parse_char and the *_chan helpers) or any other writable static:
# the bridge keeps all its state in the caller's ub_mavbridge_t (ub_config.h's rule: no hidden statics).
#   cmake -DNM=<nm> -DLIB=<libuavbus_mavbridge.a> -P no_statics_nm.cmake
execute_process(COMMAND ${NM} ${LIB} OUTPUT_VARIABLE out RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} ${LIB} failed (${rc})")
endif()
string(REPLACE "\n" ";" lines "${out}")
set(member "?")
set(offenders "")
foreach(line ${lines})
  if(line MATCHES "^(.+):$")
    set(member "${CMAKE_MATCH_1}")
  elseif(line MATCHES " [bBdD] (.+)$")
    # Writable data in the library. The generated directory storage (mav_directories.c: one struct per
    # message, the status) is the application's data, like flightsw_data.c; everything else is a finding.
    if(NOT member MATCHES "mav_directories")
      list(APPEND offenders "${member}: ${CMAKE_MATCH_1}")
    endif()
  endif()
endforeach()
if(offenders)
  string(REPLACE ";" "\n  " listing "${offenders}")
  message(FATAL_ERROR "writable static data in the MAVLink bridge library:\n  ${listing}")
endif()
message(STATUS "no writable statics in ${LIB} outside the directory storage")
