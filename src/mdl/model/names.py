"""Identifiers from names (SPEC section 3), the same under every Python version.

The rule:

1. A function or device name becomes an identifier: fold to ASCII, lowercase, every run of other
   characters -> `_`, strip `_` at both ends (`unnamed` if nothing is left), prefix `f_` if it starts
   with a digit.
2. An identifier in RESERVED gets `_` appended (`type` -> `type_`, `int32_t` -> `int32_t_`,
   `_Bool` -> `bool_`). RESERVED is one fixed union, written out below rather than taken from the
   running interpreter, so a name maps the same way under Python 3.10 and 3.13: the keywords of
   Python 3.12 (hard and soft), of C++ (C++20, alternative tokens included) and of C (C99/C11); the
   C/C++ type names and literals a generated member could hide (`int32_t`, `size_t`, `true`,
   `nullptr`, ...); the lowercase macros of the C and C++ standard headers (`errno`, `stdin`, ...);
   and the names the generated files use themselves (`all`, as `read_all`; `modbus`, `pymodbus`,
   `math`, `struct`, `decimal`, `typing`, `collections`, which a generated file includes or imports
   and so must not be its stem).
3. Within one device a name whose identifier an earlier name already has gets `_2`, `_3`, ...
   (after a trailing `_`: `type_` -> `type_2`, never a double underscore).
3a. The device's file stem (`stem`) is its identifier, with `_` appended if it is the name of a
   standard header: of C99 (`string`, `math`, `time`, `stdint`, ...) or of C++17 (`vector`, `map`,
   `cstdint`, `string_view`, ...), STANDARD_HEADERS below, fixed like RESERVED. A generated
   `<stem>.h` (or a C target's) then never has a standard header's name, with `.h` or without, so a
   compiler searching the output directory cannot take it for the standard one: `String` ->
   `string_.h`, `Time` -> `time_.py`. The rule is for the stem only: a function called `time` still
   reads as `read_time`.
3b. A stem is at most STEM_LIMIT (64) characters, so that file names derived from it (and the
   hidden temporary files beside them) fit every file system: a longer identifier keeps its first 55
   characters (less a trailing `_`) and gets `_` and 8 hex digits of its SHA-256, the same for the
   same name on every run and different for different long names. `mdl gen` says so with a note.
4. The class name is the CamelCase of the device's identifier, `Device` in front if it would start
   with a digit, and `_` appended if it is in CLASS_RESERVED: the names the generated files define
   or import at the level of the class (`Request`, `Group`, `Table`, `Regs` in the .cc;
   `DeviceError`, `CommunicationError`, `ModbusExceptionError`, `ValueRangeError`, and the imported
   `ModbusException`, `ModbusBaseClient`, `ModbusBaseSyncClient`, `ModbusPDU`, `TypedDict`,
   `Sequence` in the .py) and every capitalized Python builtin (`None`, `True`, `Exception`, ...).
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Iterable

PY_HARD_KEYWORDS = frozenset(
    """False None True and as assert async await break class continue def del elif else except
    finally for from global if import in is lambda nonlocal not or pass raise return try while with
    yield""".split()
)
PY_SOFT_KEYWORDS = frozenset("match case type _".split())
CPP_KEYWORDS = frozenset(
    """alignas alignof and and_eq asm auto bitand bitor bool break case catch char char8_t char16_t
    char32_t class compl concept const consteval constexpr constinit const_cast continue co_await
    co_return co_yield decltype default delete do double dynamic_cast else enum explicit export
    extern false float for friend goto if inline int long mutable namespace new noexcept not not_eq
    nullptr operator or or_eq private protected public register reinterpret_cast requires return
    short signed sizeof static static_assert static_cast struct switch template this thread_local
    throw true try typedef typeid typename union unsigned using virtual void volatile wchar_t while
    xor xor_eq""".split()
)
C_KEYWORDS = frozenset(
    """auto break case char const continue default do double else enum extern float for goto if
    inline int long register restrict return short signed sizeof static struct switch typedef union
    unsigned void volatile while _Alignas _Alignof _Atomic _Bool _Complex _Generic _Imaginary
    _Noreturn _Static_assert _Thread_local""".split()
)
C_TYPES = frozenset(
    """int8_t int16_t int32_t int64_t uint8_t uint16_t uint32_t uint64_t intptr_t uintptr_t
    intmax_t uintmax_t size_t ssize_t ptrdiff_t bool true false NULL nullptr""".split()
)
C_MACROS = frozenset(
    """errno assert stdin stdout stderr offsetof setjmp va_arg va_start va_end va_copy
    math_errhandling unix linux i386""".split()
)
GENERATED = frozenset("all modbus pymodbus math struct decimal typing collections".split())
RESERVED = PY_HARD_KEYWORDS | PY_SOFT_KEYWORDS | CPP_KEYWORDS | C_KEYWORDS | C_TYPES | C_MACROS | GENERATED

C99_HEADERS = frozenset(
    """assert complex ctype errno fenv float inttypes iso646 limits locale math setjmp signal stdarg
    stdbool stddef stdint stdio stdlib string tgmath time wchar wctype""".split()
)
CPP17_HEADERS = frozenset(
    """algorithm any array atomic bitset cassert ccomplex cctype cerrno cfenv cfloat charconv chrono
    cinttypes ciso646 climits clocale cmath codecvt complex condition_variable csetjmp csignal
    cstdalign cstdarg cstdbool cstddef cstdint cstdio cstdlib cstring ctgmath ctime cuchar cwchar
    cwctype deque exception execution filesystem forward_list fstream functional future
    initializer_list iomanip ios iosfwd iostream istream iterator limits list locale map memory
    memory_resource mutex new numeric optional ostream queue random ratio regex scoped_allocator set
    shared_mutex sstream stack stdexcept streambuf string string_view strstream system_error thread
    tuple type_traits typeindex typeinfo unordered_map unordered_set utility valarray variant
    vector""".split()
)
STANDARD_HEADERS = C99_HEADERS | CPP17_HEADERS

PY_BUILTIN_CLASSES = frozenset(
    """ArithmeticError AssertionError AttributeError BaseException BaseExceptionGroup
    BlockingIOError BrokenPipeError BufferError BytesWarning ChildProcessError
    ConnectionAbortedError ConnectionError ConnectionRefusedError ConnectionResetError
    DeprecationWarning EOFError Ellipsis EncodingWarning EnvironmentError Exception ExceptionGroup
    False FileExistsError FileNotFoundError FloatingPointError FutureWarning GeneratorExit IOError
    ImportError ImportWarning IndentationError IndexError InterruptedError IsADirectoryError
    KeyError KeyboardInterrupt LookupError MemoryError ModuleNotFoundError NameError None
    NotADirectoryError NotImplemented NotImplementedError OSError OverflowError
    PendingDeprecationWarning PermissionError ProcessLookupError PythonFinalizationError
    RecursionError ReferenceError ResourceWarning RuntimeError RuntimeWarning StopAsyncIteration
    StopIteration SyntaxError SyntaxWarning SystemError SystemExit TabError TimeoutError True
    TypeError UnboundLocalError UnicodeDecodeError UnicodeEncodeError UnicodeError
    UnicodeTranslateError UnicodeWarning UserWarning ValueError Warning WindowsError
    ZeroDivisionError""".split()
)
GENERATED_CLASSES = frozenset(
    """Request Group Table Regs DeviceError CommunicationError ModbusExceptionError ValueRangeError
    ModbusException ModbusBaseClient ModbusBaseSyncClient ModbusPDU TypedDict Sequence""".split()
)
CLASS_RESERVED = PY_BUILTIN_CLASSES | GENERATED_CLASSES


# a pattern's text, compiled where it is used (re.compile keeps it): no compiling at import (issue 40)
_NOT_IDENT = r"[^a-z0-9]+"


def identifier(name: str) -> str:
    # ASCII text is its own NFKD form: only other names need folding (asked of every function)
    folded = name if name.isascii() else unicodedata.normalize("NFKD", name).encode("ascii", "ignore").decode("ascii")
    ident = re.compile(_NOT_IDENT).sub("_", folded.lower()).strip("_")
    if not ident:
        ident = "unnamed"
    if ident[0].isdigit():
        ident = "f_" + ident
    if ident in RESERVED:
        ident += "_"
    return ident


STEM_LIMIT = 64  # characters of a stem: `.<stem>.cc.<12 hex>.tmp` stays far below any file system's 255


def stem(device_name: str) -> str:
    """The stem of a device's generated files: its identifier, `_` appended if a standard header's
    name; a longer one than STEM_LIMIT is shortened (stem_shortened)."""
    ident = identifier(device_name)
    if len(ident) > STEM_LIMIT:
        import hashlib  # here: only a long name needs it (OpenSSL's bindings, for every command else)

        digest = hashlib.sha256(ident.encode("ascii")).hexdigest()[:_STEM_HASH]
        return f"{ident[: STEM_LIMIT - _STEM_HASH - 1].rstrip('_')}_{digest}"
    return ident + "_" if ident in STANDARD_HEADERS else ident


def stem_shortened(device_name: str) -> bool:
    """Whether the device's identifier was too long to be its stem (rule 3b)."""
    return len(identifier(device_name)) > STEM_LIMIT


_STEM_HASH = 8  # hex digits of the identifier's SHA-256 that keep shortened stems apart


def unique_identifiers(names: Iterable[str]) -> list[str]:
    """Identifiers for names in order; a collision with an earlier one gets _2, _3, ..."""
    seen: set[str] = set()
    out = []
    for name in names:
        base = identifier(name)
        ident, n = base, 1
        while ident in seen:
            n += 1
            ident = f"{base.rstrip('_')}_{n}"
        seen.add(ident)
        out.append(ident)
    return out


def camel(ident: str) -> str:
    cls = "".join(part[:1].upper() + part[1:] for part in ident.split("_") if part)
    cls = cls if cls and not cls[0].isdigit() else "Device" + cls
    return cls + "_" if cls in CLASS_RESERVED else cls
