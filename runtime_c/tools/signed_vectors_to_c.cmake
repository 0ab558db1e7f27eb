# Turns tests/vectors/signed_frames.json into a C header for test_sec_vectors.c.
# Run as a build step (see runtime_c/tests/sec.cmake):
#   cmake -DIN=signed_frames.json -DOUT=ub_signed_vectors.h -P signed_vectors_to_c.cmake
# Plain CMake, so the C build needs no Python (nor PyNaCl) to read the vectors.
cmake_minimum_required(VERSION 3.20)
if(NOT IN OR NOT OUT)
  message(FATAL_ERROR "usage: cmake -DIN=signed_frames.json -DOUT=header.h -P signed_vectors_to_c.cmake")
endif()

file(READ "${IN}" json)
get_filename_component(in_name "${IN}" NAME)

include(${CMAKE_CURRENT_LIST_DIR}/vectors_common.cmake)

set(keys "")
string(JSON nkeys LENGTH "${json}" keys)
math(EXPR lastkey "${nkeys} - 1")
foreach(i RANGE ${lastkey})
  string(JSON kid MEMBER "${json}" keys ${i})
  string(JSON khex GET "${json}" keys ${kid})
  hex_to_c("${khex}" kc)
  string(JSON sighex GET "${json}" subkeys ${kid} sig)
  string(JSON aeadhex GET "${json}" subkeys ${kid} aead)
  hex_to_c("${sighex}" sigc)
  hex_to_c("${aeadhex}" aeadc)
  string(APPEND keys "    {${kid}u, {${kc}}, {${sigc}}, {${aeadc}}},\n")
endforeach()

set(arrays "")
set(rows "")
string(JSON count LENGTH "${json}" vectors)
math(EXPR last "${count} - 1")
foreach(i RANGE ${last})
  foreach(key name mode key_id counter dir_id dest_id src_id admin hop_limit fingerprint payload frame)
    string(JSON ${key} GET "${json}" vectors ${i} ${key})
  endforeach()
  foreach(key dir_id dest_id src_id payload frame)
    hex_to_c("${${key}}" ${key}_c)
  endforeach()
  hex_len("${payload}" payload_len)
  hex_len("${frame}" frame_len)
  if(mode STREQUAL "signed")
    set(flags "UB_FRAME_FLAG_SIGNED")
  else()
    set(flags "UB_FRAME_FLAG_ENCRYPTED")
  endif()
  string(APPEND arrays "static const uint8_t sv${i}_payload[] = {${payload_c}};\n")
  string(APPEND arrays "static const uint8_t sv${i}_frame[] = {${frame_c}};\n")
  string(APPEND rows "    {\"${name}\", ${flags}, ${key_id}u, UINT64_C(${counter}), {${dir_id_c}}, {${dest_id_c}}, {${src_id_c}},\n")
  string(APPEND rows "     ${admin}u, ${hop_limit}u, ${fingerprint}u, sv${i}_payload, ${payload_len}u, sv${i}_frame, ${frame_len}u},\n")
endforeach()

set(rej_arrays "")
set(rej_rows "")
string(JSON rcount LENGTH "${json}" rejects)
math(EXPR rlast "${rcount} - 1")
foreach(i RANGE ${rlast})
  string(JSON rname GET "${json}" rejects ${i} name)
  string(JSON rexpect GET "${json}" rejects ${i} expect)
  string(JSON rframe GET "${json}" rejects ${i} frame)
  hex_to_c("${rframe}" rframe_c)
  hex_len("${rframe}" rframe_len)
  string(APPEND rej_arrays "static const uint8_t rj${i}_frame[] = {${rframe_c}};\n")
  string(APPEND rej_rows "    {\"${rname}\", \"${rexpect}\", rj${i}_frame, ${rframe_len}u},\n")
endforeach()

file(WRITE "${OUT}" "/* Generated from tests/vectors/${in_name} by runtime_c/tools/signed_vectors_to_c.cmake. Do not edit. */
#ifndef UB_SIGNED_VECTORS_H
#define UB_SIGNED_VECTORS_H
#include <stddef.h>
#include <stdint.h>
#include \"ub/ub_frame.h\"

/* key: the key file's key; sig, aead: its subkeys (libsodium KDF, contexts \"ubsig001\" / \"ubaead01\", id 1) */
typedef struct signed_key { uint8_t id; uint8_t key[32]; uint8_t sig[16]; uint8_t aead[32]; } signed_key_t;
typedef struct signed_vector {
    const char *name;
    uint8_t flags;
    uint8_t key_id;
    uint64_t counter;
    uint8_t dir_id[16];
    uint8_t dest_id[12];
    uint8_t src_id[12];
    uint8_t admin;
    uint8_t hop_limit;
    uint32_t fingerprint;
    const uint8_t *payload;
    size_t payload_len;
    const uint8_t *frame;
    size_t frame_len;
} signed_vector_t;
typedef struct signed_reject { const char *name; const char *expect; const uint8_t *frame; size_t frame_len; } signed_reject_t;

static const signed_key_t signed_keys[] = {
${keys}};
#define SIGNED_KEY_COUNT ${nkeys}u

${arrays}
static const signed_vector_t signed_vectors[] = {
${rows}};
#define SIGNED_VECTOR_COUNT ${count}u

${rej_arrays}
static const signed_reject_t signed_rejects[] = {
${rej_rows}};
#define SIGNED_REJECT_COUNT ${rcount}u
#endif
")
