// Parameter groups: each configuration struct has a live copy and a scratch copy, both declared by
// one macro (so the instances come from macro expansion, as in the real code base).
#pragma once

#include "platform.h"

#define PG_DECLARE(_type, _name)                                                                      \
    extern _type _name##_System;                                                                       \
    extern _type _name##_Copy;                                                                         \
    static inline const _type *_name(void) { return &_name##_System; }                                 \
    struct _dummy

#define PG_DECLARE_ARRAY(_type, _length, _name)                                                       \
    extern _type _name##_SystemArray[_length];                                                         \
    extern _type _name##_CopyArray[_length];                                                           \
    static inline const _type *_name(int _index) { return &_name##_SystemArray[_index]; }              \
    struct _dummy

#define PG_REGISTER(_type, _name) _type _name##_System; _type _name##_Copy
#define PG_REGISTER_ARRAY(_type, _length, _name)                                                      \
    _type _name##_SystemArray[_length];                                                                \
    _type _name##_CopyArray[_length]
