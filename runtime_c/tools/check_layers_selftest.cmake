# The test of the layering check (ub_layer_check_selftest): the check must pass on the tree as it is and
# fail on a planted breach, each kind on its own, or it proves nothing.
#   cmake -DSRC=<runtime_c/src> -DINC=<runtime_c/include> -DCHECK=<check_layers.cmake> -DWORK=<scratch dir> -P ...
if(NOT SRC OR NOT INC OR NOT CHECK OR NOT WORK)
  message(FATAL_ERROR "usage: cmake -DSRC=... -DINC=... -DCHECK=... -DWORK=... -P check_layers_selftest.cmake")
endif()

# Runs the check with extra -D arguments; `expect_fail`: whether it must fail, `needle`: what it must say.
function(run_check name expect_fail needle)
  execute_process(COMMAND ${CMAKE_COMMAND} -DSRC=${SRC} -DINC=${INC} ${ARGN} -P ${CHECK}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(expect_fail AND rc EQUAL 0)
    message(FATAL_ERROR "${name}: the layering check passed on a planted breach:\n${out}${err}")
  elseif(NOT expect_fail AND NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: the layering check failed on the tree as it is:\n${out}${err}")
  endif()
  if(needle AND NOT "${out}${err}" MATCHES "${needle}")
    message(FATAL_ERROR "${name}: the check did not name the breach (${needle}):\n${out}${err}")
  endif()
  message(STATUS "${name}: as expected")
endfunction()

run_check("clean tree" FALSE "")

# A copy of one service with one planted line each; the rest of svc/ is copied too, so only the plant differs.
function(plant kind file line)
  set(dir "${WORK}/${kind}")
  file(REMOVE_RECURSE "${dir}")
  file(MAKE_DIRECTORY "${dir}")
  file(GLOB originals "${SRC}/${kind}/*.c" "${SRC}/${kind}/*.h")
  file(COPY ${originals} DESTINATION "${dir}")
  file(APPEND "${dir}/${file}" "\n${line}\n")
endfunction()

plant(svc ub_member.c "static int planted(const ub_node_t *node) { return node->x; }")
run_check("node-> in a service" TRUE "ub_member.c:[0-9]+: a service dereferences the node struct" -DSVC_DIR=${WORK}/svc)

plant(svc ub_route.c "static int planted(const ub_route_t *rt) { return rt->node->locals[0].in_use; }")
run_check("rt->node-> in a service" TRUE "ub_route.c:[0-9]+: a service dereferences" -DSVC_DIR=${WORK}/svc)

plant(svc ub_inspect.c "static int planted(const struct ub_node *n) { return n->entities[0].in_use; }")
run_check("a ub_node_t member in a service" TRUE "ub_inspect.c:[0-9]+: a service reads a ub_node_t member \\(entities\\)"
          -DSVC_DIR=${WORK}/svc)

plant(svc ub_pubsub.c "#include \"core/ub_node_private.h\"")
run_check("a core include in a service" TRUE "ub_pubsub.c:[0-9]+: a service includes a private header" -DSVC_DIR=${WORK}/svc)

plant(codec ub_frame.c "#include \"ub/ub_node.h\"")
run_check("the node in the wire layer" TRUE "ub_frame.c:[0-9]+: the wire layer includes ub/ub_node.h" -DCODEC_DIR=${WORK}/codec)

plant(codec ub_frag.c "#include \"svc/ub_svc_private.h\"")
run_check("a service header in the wire layer" TRUE "ub_frag.c:[0-9]+: the wire layer includes" -DCODEC_DIR=${WORK}/codec)

file(REMOVE_RECURSE "${WORK}/svc" "${WORK}/codec")
