"""The one number formatter (vrelab._format): GUM 7.2.6 rounding, units, tiny and huge numbers.

Expected strings are written by hand from the rule (JCGM 100:2008, 7.2.6: u quoted with at most
two significant digits, the value rounded at the same decimal place), not from the code.
"""

import html
import re

from vrelab._format import format_mg_text, format_u, format_value, format_value_u


def test_gum_726_u_two_digits_value_at_its_last_digit():
    # The issue's own examples: 20908 ± 538 and 2849.57 ± 72 (campaign VRCs), 2.64 ± 0.015 g.
    assert format_value_u(20908, 538, unit="µg/g²") == "20910 ± 540 µg/g²"
    assert format_value_u(2849.57, 72) == "2850 ± 72"
    assert format_value_u(2.6431, 0.0149, unit="g") == "2.643 ± 0.015 g"
    assert format_value_u(1062.3, 23) == "1062 ± 23"


def test_rounding_that_carries_into_a_new_digit_keeps_two_digits():
    # 0.0996 rounds to 0.10 (two digits), not 0.100.
    assert format_value_u(1.0, 0.0996) == "1.00 ± 0.10"
    assert format_u(0.0996) == "0.10"


def test_u_alone_and_mg():
    assert [format_u(x) for x in (0.08156, 1.6, 3.299, 538)] == ["0.082", "1.6", "3.3", "540"]
    assert format_mg_text(-0.08350, 0.00041) == "-83.50 ± 0.41 mg"
    assert format_mg_text(None) == "–"


def test_tiny_and_huge_numbers_never_print_long_exponents():
    # Below the resolution a value is 0 (the prediction table's -8.943e-112 mg).
    assert format_value(-8.943e-112, resolution=0.001, unit="mg") == "0 mg"
    assert format_value(1.4e-62, signed=True, resolution=0.001) == "0"
    assert format_value(-1.2345e-3, resolution=0.001) == "-0.001"
    assert format_value_u(3e-5, 1e-6, unit="g") == "(3.00 ± 0.10)·10⁻⁵ g"


def test_value_without_u_four_digits_no_false_zeros():
    assert format_value(4000.0, unit="Hz") == "4000 Hz"
    assert format_value(0.30012) == "0.3001"
    assert format_value(0.3, signed=True) == "+0.3"
    assert format_value(float("nan")) == "–"
    assert format_value(123456789) == "123456789"  # a count keeps all its digits
    assert format_value_u(-0.00001, 0.0149) == "0.000 ± 0.015"  # never "-0.000"
    assert format_value(2.1, resolution=0.01) == "2.10"  # a coverage factor k to 0.01


# ----------------------------------------------------------------------------- rendered text
# Readers of rendered output (the report's HTML, the CLI's stdout) used by the report tests.
_PAIR = re.compile(r"(?<![\w.·])([-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?) ± (\d+(?:\.\d+)?(?:e[-+]?\d+)?)(?![\d.]|·10)")


def visible_text(html_text: str) -> str:
    """What a reader sees of a report: no scripts, styles or tags, entities decoded."""
    t = re.sub(r"<(script|style)\b.*?</\1>", " ", html_text, flags=re.S)
    return html.unescape(re.sub(r"<[^>]+>", " ", t))


def gum_violations(text: str) -> list[str]:
    """Every ``value ± u`` in ``text`` that breaks GUM 7.2.6 as the issue states it: u with two
    significant digits (an integer u may end in a rounding zero: 540), the value to u's last
    decimal, no exponent notation."""
    bad = []
    for m in _PAIR.finditer(text):
        v, u = m.groups()
        dec = [len(x.split(".")[1]) if "." in x else 0 for x in (v, u)]
        digits = u.replace(".", "").lstrip("0")
        two = len(digits) == 2 or ("." not in u and len(digits) > 2 and set(digits[2:]) == {"0"})
        if "e" in v + u or dec[0] != dec[1] or not two:
            bad.append(text[max(0, m.start() - 40):m.end()].replace("\n", " "))
    return bad


def test_the_rendered_text_checker_finds_the_issues_examples():
    # The issue's "today" column: every one of these breaks the rule; the fixed forms do not.
    today = "2.64 ± 0.015 g, 20908 ± 538, 2849.57 ± 72, prose 1.06e+03 ± 23, 2.66 ± 0.037 g"
    assert len(gum_violations(today)) == 5
    assert gum_violations("2.640 ± 0.015 g, 20910 ± 540, 2850 ± 72, 1062 ± 23, ±2 g, ±3 dB") == []
    assert visible_text("<p>a <b>1</b> &lt; 2<script>x ± y</script></p>").split() == ["a", "1", "<", "2"]
