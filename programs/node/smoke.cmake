# Smoke test of uavbus_node (ctest programs_uavbus_node_smoke): one process with a UDP port publishing
# gpsOut for 300 ms exits 0 with a ready event, stats and frames sent, waking only for what is due; a bad port spec exits 2 with a
# message naming the argument. The multi-process behaviour is tested from Python (tests/system).
#   cmake -DNODE=<uavbus_node> -DCONFIG=<table2.json> -P smoke.cmake
execute_process(
  COMMAND ${NODE} --config ${CONFIG} --node primary
          --port onboardPortRelay=udp:bind=127.0.0.1:0,peer=127.0.0.1:9
          --publish rmax1ob1:gpsOut>fcs20/20 --duration-ms 300 --stats-ms 100
  INPUT_FILE /dev/null OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 20)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "uavbus_node exited ${rc}, expected 0\nstdout: ${out}\nstderr: ${err}")
endif()
foreach(want "\"event\":\"ready\",\"node\":\"primary\"" "\"local_port\":[1-9]" "\"final\":true"
        "\"onboardPortRelay\":{\"id\":3,\"frames_in\":0,\"bytes_in\":0,\"frames_out\":[1-9]")
  if(NOT out MATCHES "${want}")
    message(FATAL_ERROR "uavbus_node output lacks /${want}/:\n${out}")
  endif()
endforeach()
# The loop sleeps until the next due time (ub_node_next_due(), the stats); the motion models are sampled lazily
# and wake nothing. In 300 ms it wakes for the 15 publications, the ICMP "port unreachable" each one brings back
# from port 9, and the stats: 31 here. Sampling the 10 ms model eagerly woke it 46 times, a 1 ms loop ~300
# (tests/system/test_node_wakeups.py bounds an idle node with a wider margin).
string(REGEX MATCH "\"final\":true[^\n]*\"wakeups\":([0-9]+)" final_line "${out}")
if(NOT CMAKE_MATCH_1 OR CMAKE_MATCH_1 GREATER 40)
  message(FATAL_ERROR "uavbus_node woke ${CMAKE_MATCH_1} times in 300 ms (expected <= 40: it should sleep until its next due time):\n${out}")
endif()
execute_process(
  COMMAND ${NODE} --config ${CONFIG} --node primary --port onboardPortRelay=udp:peer=127.0.0.1:9
  INPUT_FILE /dev/null OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 20)
if(NOT rc EQUAL 2 OR NOT err MATCHES "^uavbus_node:argv\\[6\\]: port 'onboardPortRelay': udp needs bind=")
  message(FATAL_ERROR "bad spec: exit ${rc} (expected 2), stderr: ${err}")
endif()
