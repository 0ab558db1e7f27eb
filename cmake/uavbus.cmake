# uavbus.cmake: build-time code generation for flight software.
#
#   find_package(uavbus CONFIG REQUIRED)        # installed package: includes this file
#   # or: add_subdirectory(<uavbus>) / FetchContent_MakeAvailable(uavbus)
#   uavbus_generate(TARGET <lib> NAME <name> HEADERS <header>...
#                   [INCLUDE_DIRS <dir>...] [DEFINES <NAME[=VAL]>...]
#                   [ID_SCHEME paper|hashed] [OUTPUT_DIR <dir>]
#                   [STD <c-standard>] [CLANG_ARGS <arg>...] [DEPENDS <file>...])
#
# At build time, runs `${UAVBUS_PYTHON} -m uavbus.cli gen` on HEADERS and writes
# into OUTPUT_DIR (default: ${CMAKE_CURRENT_BINARY_DIR}/uavbus/<name>):
#   <name>.h, <name>.c          ID constants, the `<name>_catalogue` table, pack/unpack per type
#   <name>.catalogue.json       the checked catalogue (schemas/catalogue.schema.json)
#   <name>.py                   the same catalogue and per-type bindings for Python
# Then defines the static library <lib> of the generated C, linked to the runtime
# library `uavbus::ub` (so the runtime must be there: find_package(uavbus) or
# add_subdirectory(<uavbus>) first). Users of <lib> get
# OUTPUT_DIR, the INCLUDE_DIRS and every header's own directory as include
# directories and DEFINES as compile definitions, so they see the headers the
# way the generator did.
#
# The generated C checks that each struct's size and member offsets are the ones the catalogue
# describes, so the headers must be parsed as the target compiles them. A cross build passes the
# target to the generator's clang (`--target=<triple>`): UAVBUS_GEN_TARGET, by default the compiler's
# target when cross-compiling (CMAKE_C_COMPILER_TARGET, else the Linux multiarch triple CMake found,
# CMAKE_LIBRARY_ARCHITECTURE, e.g. s390x-linux-gnu). A bare-metal cross build (no such triple) parses
# as the host does unless UAVBUS_GEN_TARGET is set.
#
# UAVBUS_PYTHON is the Python that has the uavbus package (`pip install uavbus`);
# default: the repository's .venv when there is one, else the python3 on PATH. It is
# checked once, at configure time, with a message saying what to do.
#
# The generator reruns when a listed header, a generator source or a template
# changes. Headers that the listed ones include from elsewhere are not tracked:
# list them in HEADERS or DEPENDS. A collision or parse error fails the build
# with the generator's `file:line: message` output.
#
# Properties set on <lib> for callers: UAVBUS_OUTPUT_DIR, UAVBUS_CATALOGUE_JSON.

include_guard(GLOBAL)

get_filename_component(UAVBUS_ROOT "${CMAKE_CURRENT_LIST_DIR}/.." ABSOLUTE)
if(NOT DEFINED UAVBUS_PYTHON)
  if(EXISTS "${UAVBUS_ROOT}/.venv/bin/python")
    set(_uavbus_python "${UAVBUS_ROOT}/.venv/bin/python")
  else()
    find_program(_uavbus_python NAMES python3 python)
  endif()
  set(UAVBUS_PYTHON "${_uavbus_python}" CACHE FILEPATH "Python with the uavbus package installed")
endif()

# Checks once that UAVBUS_PYTHON can run the generator, so a missing package is one clear
# configure-time message rather than a failure deep in the build.
function(_uavbus_check_python)
  get_property(checked GLOBAL PROPERTY _UAVBUS_PYTHON_CHECKED)
  if(checked STREQUAL "${UAVBUS_PYTHON}")
    return()
  endif()
  execute_process(COMMAND "${UAVBUS_PYTHON}" -c "import uavbus_gen.cli"
                  RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "uavbus_generate: '${UAVBUS_PYTHON}' cannot run the uavbus generator "
                        "(import uavbus_gen failed). Install it (`python3 -m pip install uavbus`, or "
                        "`make setup` in a uavbus checkout) and pass -DUAVBUS_PYTHON=<that python>.")
  endif()
  set_property(GLOBAL PROPERTY _UAVBUS_PYTHON_CHECKED "${UAVBUS_PYTHON}")
endfunction()

function(uavbus_generate)
  cmake_parse_arguments(PARSE_ARGV 0 ARG
    ""
    "TARGET;NAME;ID_SCHEME;OUTPUT_DIR;STD"
    "HEADERS;INCLUDE_DIRS;DEFINES;CLANG_ARGS;DEPENDS")

  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "uavbus_generate: unknown arguments: ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  foreach(required TARGET NAME HEADERS)
    if(NOT ARG_${required})
      message(FATAL_ERROR "uavbus_generate: ${required} is required")
    endif()
  endforeach()
  if(NOT ARG_NAME MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "uavbus_generate: NAME '${ARG_NAME}' must be a C identifier (it prefixes generated symbols)")
  endif()
  if(NOT ARG_ID_SCHEME)
    set(ARG_ID_SCHEME paper)
  endif()
  if(NOT ARG_ID_SCHEME MATCHES "^(paper|hashed)$")
    message(FATAL_ERROR "uavbus_generate: ID_SCHEME must be paper or hashed, not '${ARG_ID_SCHEME}'")
  endif()
  if(NOT TARGET uavbus::ub)
    message(FATAL_ERROR "uavbus_generate: the runtime library uavbus::ub does not exist yet; "
                        "call find_package(uavbus CONFIG REQUIRED) or add_subdirectory(<uavbus>) first")
  endif()
  _uavbus_check_python()
  if(NOT ARG_OUTPUT_DIR)
    set(ARG_OUTPUT_DIR "${CMAKE_CURRENT_BINARY_DIR}/uavbus/${ARG_NAME}")
  endif()
  get_filename_component(out_dir "${ARG_OUTPUT_DIR}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_BINARY_DIR}")

  # The command line and the library must name the same absolute paths, whatever
  # directory the caller's relative paths were written against.
  set(headers "")
  set(header_dirs "")
  foreach(header IN LISTS ARG_HEADERS)
    get_filename_component(abs "${header}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    if(NOT EXISTS "${abs}")
      message(FATAL_ERROR "uavbus_generate: header not found: ${abs}")
    endif()
    list(APPEND headers "${abs}")
    get_filename_component(dir "${abs}" DIRECTORY)
    list(APPEND header_dirs "${dir}")
  endforeach()
  list(REMOVE_DUPLICATES header_dirs)

  set(include_dirs "")
  set(gen_args "")
  foreach(dir IN LISTS ARG_INCLUDE_DIRS)
    get_filename_component(abs "${dir}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND include_dirs "${abs}")
    list(APPEND gen_args "-I" "${abs}")
  endforeach()
  foreach(def IN LISTS ARG_DEFINES)
    list(APPEND gen_args "-D" "${def}")
  endforeach()
  if(ARG_STD)
    list(APPEND gen_args "--std" "${ARG_STD}")
  endif()
  list(APPEND gen_args "--name" "${ARG_NAME}" "--id-scheme" "${ARG_ID_SCHEME}" "-o" "${out_dir}")
  set(clang_args ${ARG_CLANG_ARGS})
  set(gen_target "${UAVBUS_GEN_TARGET}")
  if(NOT gen_target AND CMAKE_CROSSCOMPILING)
    if(CMAKE_C_COMPILER_TARGET)
      set(gen_target "${CMAKE_C_COMPILER_TARGET}")
    elseif(CMAKE_LIBRARY_ARCHITECTURE)
      set(gen_target "${CMAKE_LIBRARY_ARCHITECTURE}")
    endif()
  endif()
  if(gen_target)
    list(APPEND clang_args "--target=${gen_target}")
  endif()
  if(clang_args)
    list(APPEND gen_args "--" ${clang_args})
  endif()

  # Editing the generator or a template must regenerate, exactly like editing a header.
  file(GLOB_RECURSE generator_sources CONFIGURE_DEPENDS
    "${UAVBUS_ROOT}/generator/*.py"
    "${UAVBUS_ROOT}/templates/*"
    "${UAVBUS_ROOT}/runtime_py/uavbus/cli.py")

  set(outputs
    "${out_dir}/${ARG_NAME}.h"
    "${out_dir}/${ARG_NAME}.c"
    "${out_dir}/${ARG_NAME}.catalogue.json"
    "${out_dir}/${ARG_NAME}.py")
  list(LENGTH headers n_headers)

  # The trailing touch keeps every output newer than its inputs even if the
  # generator leaves byte-identical files alone, so the step never reruns idly.
  # It never creates a file: an output the generator stopped writing stays
  # missing, and the build reruns the step (tests/integration catch that).
  add_custom_command(
    OUTPUT ${outputs}
    COMMAND "${UAVBUS_PYTHON}" -m uavbus.cli gen ${headers} ${gen_args}
    COMMAND "${CMAKE_COMMAND}" -E touch_nocreate ${outputs}
    DEPENDS ${headers} ${generator_sources} ${ARG_DEPENDS}
    WORKING_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}"
    COMMENT "uavbus: generating catalogue '${ARG_NAME}' from ${n_headers} header(s)"
    VERBATIM)

  add_library(${ARG_TARGET} STATIC "${out_dir}/${ARG_NAME}.c" "${out_dir}/${ARG_NAME}.h")
  # Warnings inside the input headers are their owners' business, not the
  # generated code's: the library itself sees them as system headers (real
  # headers such as MAVLink's trip -Werror otherwise), its users as usual.
  target_include_directories(${ARG_TARGET} PUBLIC "${out_dir}")
  target_include_directories(${ARG_TARGET} SYSTEM PRIVATE ${include_dirs} ${header_dirs})
  target_include_directories(${ARG_TARGET} INTERFACE ${include_dirs} ${header_dirs})
  if(ARG_DEFINES)
    target_compile_definitions(${ARG_TARGET} PUBLIC ${ARG_DEFINES})
  endif()
  target_link_libraries(${ARG_TARGET} PUBLIC uavbus::ub)
  set_target_properties(${ARG_TARGET} PROPERTIES
    UAVBUS_OUTPUT_DIR "${out_dir}"
    UAVBUS_CATALOGUE_JSON "${out_dir}/${ARG_NAME}.catalogue.json")
endfunction()
