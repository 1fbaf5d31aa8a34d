"""templating.ccomment's shortcut (issue 29): text that is printable ASCII between two visible characters,
without `*/`, `/*` or `??/`, is returned as it is; every text must come out exactly as the general way
(control characters, hidden characters, comment ends, trigraphs, a final backslash) prints it."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from mdl.targets.templating import _ccomment, ccomment

# mostly the characters that matter: comment ends, trigraphs, backslashes, spaces, controls, hidden ones
CHARS = st.sampled_from(list("*/?\\ \t\n\x00\x7f\x85\u202e\u200b°aZ09!~")) | st.characters()


@settings(max_examples=300, deadline=None)
@given(st.text(CHARS, max_size=12))
def test_the_shortcut_prints_what_the_general_way_prints(text):
    assert ccomment(text) == _ccomment(text)
    assert "*/" not in ccomment(text) and "??/" not in ccomment(text) and not ccomment(text).endswith("\\")
