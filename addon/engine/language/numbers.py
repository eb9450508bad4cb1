"""Spelling out numbers the way they are read aloud in dialogue."""

from __future__ import annotations

_ONES = ("zero one two three four five six seven eight nine ten eleven twelve thirteen "
         "fourteen fifteen sixteen seventeen eighteen nineteen").split()
_TENS = "_ _ twenty thirty forty fifty sixty seventy eighty ninety".split()
_SCALES = ((10**12, "trillion"), (10**9, "billion"), (10**6, "million"), (1000, "thousand"))
_ORDINAL_IRREGULAR = {
    "one": "first", "two": "second", "three": "third", "five": "fifth", "eight": "eighth",
    "nine": "ninth", "twelve": "twelfth",
}


def _below_thousand(n: int) -> list[str]:
    words: list[str] = []
    if n >= 100:
        words += [_ONES[n // 100], "hundred"]
        n %= 100
    if n >= 20:
        words.append(_TENS[n // 10])
        if n % 10:
            words.append(_ONES[n % 10])
    elif n or not words:
        words.append(_ONES[n])
    return words


def cardinal(n: int) -> list[str]:
    """``1234`` -> ``one thousand two hundred thirty four``."""
    if n < 0:
        return ["minus"] + cardinal(-n)
    if n < 1000:
        return _below_thousand(n)
    words: list[str] = []
    for value, name in _SCALES:
        if n >= value:
            words += cardinal(n // value) + [name]
            n %= value
    if n:
        words += _below_thousand(n)
    return words


def ordinal(n: int) -> list[str]:
    """``3`` -> ``third``, ``21`` -> ``twenty first``."""
    words = cardinal(n)
    last = words[-1]
    if last in _ORDINAL_IRREGULAR:
        words[-1] = _ORDINAL_IRREGULAR[last]
    elif last.endswith("y"):
        words[-1] = last[:-1] + "ieth"
    else:
        words[-1] = last + "th"
    return words


def year(n: int) -> list[str]:
    """Years as spoken: 1999 -> nineteen ninety nine, 2005 -> two thousand five,
    1900 -> nineteen hundred, 2010 -> twenty ten."""
    if n < 1000 or n > 9999:
        return cardinal(n)
    hi, lo = divmod(n, 100)
    if 2000 <= n <= 2009:
        return cardinal(n)
    if lo == 0:
        return cardinal(hi) + ["hundred"]
    if lo < 10:
        return cardinal(hi) + ["oh"] + cardinal(lo)
    return cardinal(hi) + cardinal(lo)


def digits(text: str) -> list[str]:
    """Read a digit string one digit at a time (``07`` -> ``zero seven``)."""
    return [_ONES[int(ch)] for ch in text if ch.isdigit()]


def decimal(text: str) -> list[str]:
    """``3.14`` -> ``three point one four``."""
    whole, _, frac = text.partition(".")
    words = cardinal(int(whole)) if whole else ["zero"]
    if frac:
        words += ["point"] + digits(frac)
    return words
