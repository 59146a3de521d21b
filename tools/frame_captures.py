"""The frames captured from Psyclone 1.1.7 and JavaOpenAIR, for tools/gen_frame_vectors.py.

Copied verbatim from the Psyclone 1.1.7 wire transcripts (psyclone-wire/, in the project's
shared reference material; see spec/vectors/frames/README.md). The transcripts print each
frame's XML with its trailing newline removed: JavaOpenAIR (and the raw client, which imitates
it) ends its XML with "</message>\\n", so those literals end with "\\n" and their length
equals the recorded xmllen; Psyclone's own XML has no trailing newline. `RECORDED` maps each
literal's name to (literal, the xmllen the transcript recorded); gen_frame_vectors.py checks
both when it runs. Not a generator itself: tools/ is not a package, so the generator loads this
file by path.
"""

from __future__ import annotations

# -- captured XML (verbatim from the transcripts; comment = file, time, connection) ------------

J_BIND = (  # 01-connect-bind.txt +0.092s conn 1
    '<message priority="0.0" timetolive="0.0">\n'
    "\t<type>BIND</type>\n"
    "\t<id>ddc32690-385c-49da-9f96-14aa5928de9e</id>\n"
    "\t<from>Reader</from>\n"
    "\t<to>CNS</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795328337" msec="877" />\n'
    '\t<content language=""></content>\n'
    "</message>\n"
)
P_BIND_ACCEPT = (  # 01-connect-bind.txt +0.102s conn 1
    "<message>\n"
    "\t<type>BIND_ACCEPT</type>\n"
    "\t<id>9930ef03-2446-4280-8b61-b7e2424de0cf</id>\n"
    "\t<from>CNS</from>\n"
    "\t<to>Reader</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse>ddc32690-385c-49da-9f96-14aa5928de9e</isresponse>\n"
    '\t<postedTime  sec="1795328337" msec="898" tzc="Greenwich_0_60" />\n'
    '\t<content language="">10114</content>\n'
    "</message>"
)
J_RECEIVE_NAME = (  # 01-connect-bind.txt +0.108s conn 2
    '<message priority="0.0" timetolive="0.0">\n'
    "\t<type>RECEIVE_NAME_NOTIFICATION</type>\n"
    "\t<id>66285f8f-7767-41ff-b17a-cb6d755498db</id>\n"
    "\t<from>Reader</from>\n"
    "\t<to></to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795328337" msec="908" />\n'
    '\t<content language=""></content>\n'
    "</message>\n"
)
P_RESOLVE_SUCCESS = (  # 01-connect-bind.txt +0.134s conn 1
    "<message>\n"
    "\t<type>RESOLVE_SUCCESS</type>\n"
    "\t<id>4a291a82-6302-42d3-8be4-61680c757fe0</id>\n"
    "\t<from>CNS</from>\n"
    "\t<to>Reader</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse>40e66a8f-37d0-4276-86f4-fc16cd426f41</isresponse>\n"
    '\t<postedTime  sec="1795328337" msec="934" tzc="Greenwich_0_60" />\n'
    '\t<content language="xml">\n'
    '\t\t<tcplocation address="127.0.0.1" port="10101" name="Config" '
    'procid="32" ipnumber="127.0.0.1" pointer="01683088" '
    'netprotocol="" '
    'auth="127.0.0.1|024010250003025021160230402116023040211602401010'
    '24044891232112100104041102510609" additional="" />\n'
    "\t</content>\n"
    "</message>"
)
J_GET_ENTRY_GLOBAL = (  # 01-connect-bind.txt +0.139s conn 3
    '<message priority="0.0" timetolive="0.0">\n'
    "\t<type>GET_ENTRY</type>\n"
    "\t<id>40e66a8f-37d0-4276-86f4-fc16cd426f41</id>\n"
    "\t<from>Reader</from>\n"
    "\t<to>Config</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795328337" msec="910" />\n'
    '\t<content language="">Global</content>\n'
    "</message>\n"
)
J_GET_ENTRY_READER = (  # 01-connect-bind.txt +0.199s conn 3
    '<message priority="0.0" timetolive="0.0">\n'
    "\t<type>GET_ENTRY</type>\n"
    "\t<id>06b72dda-3bc7-4b6a-a749-0460d8dbf0af</id>\n"
    "\t<from>Reader</from>\n"
    "\t<to>Config</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795328337" msec="978" />\n'
    '\t<content language="">Reader</content>\n'
    "</message>\n"
)
P_ENTRY_GLOBAL = (  # 01-connect-bind.txt +0.176s conn 3
    "<message>\n"
    "\t<type>ENTRY</type>\n"
    "\t<id>486809d6-8627-4856-96fc-a0c9ab596b25</id>\n"
    "\t<from>Config</from>\n"
    "\t<to>Reader</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse>40e66a8f-37d0-4276-86f4-fc16cd426f41</isresponse>\n"
    '\t<postedTime  sec="1795328337" msec="976" tzc="Greenwich_0_60" />\n'
    '\t<content language="xml">\n'
    "\t\t<dictionary>\n"
    '\t\t\t<entry name="spec"></entry>\n'
    '\t\t\t<entry name="name">Default built-in</entry>\n'
    '\t\t\t<entry name="title">Psyclone Default</entry>\n'
    '\t\t\t<entry name="description">Default built-in PsySpec</entry>\n'
    '\t\t\t<entry name="datastorefile"></entry>\n'
    '\t\t\t<entry name="htmldir">html</entry>\n'
    "\t\t</dictionary>\n"
    "\t</content>\n"
    "</message>"
)
P_ENTRY_READER = (  # 01-connect-bind.txt +0.225s conn 3
    "<message>\n"
    "\t<type>ENTRY</type>\n"
    "\t<id>2832482e-d65c-4ef9-a8a9-7540e9bf7369</id>\n"
    "\t<from>Config</from>\n"
    "\t<to>Reader</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse>06b72dda-3bc7-4b6a-a749-0460d8dbf0af</isresponse>\n"
    '\t<postedTime  sec="1795328338" msec="25" tzc="Greenwich_0_60" />\n'
    "</message>"
)
R_E9_MINIMAL = (  # 07-errors.txt +0.102s conn 2
    "<message><type>Raw.Min</type></message>"
)
R_E11_MALFORMED = (  # 07-errors.txt +0.125s conn 2
    "<message><type>Raw.Bad</type><to>WB1</to"
)
R_E12_HELLO = (  # 07-errors.txt +0.160s conn 3
    "hello world"
)
R_E13_GARBAGE = (  # 07-errors.txt +0.174s conn 4
    "hello"
)
R_E14_PARTIAL = (  # 07-errors.txt +5.177s conn 5
    "<message><type>X</t"
)
R_E19_PING = (  # 07-errors.txt +29.201s conn 9
    '<message priority="2.0" timetolive="0.0">\n'
    "\t<type>PING</type>\n"
    "\t<id>09162616-54cf-4e64-80bf-2fc0ea4830a3</id>\n"
    "\t<from>RawClient</from>\n"
    "\t<to>CNS</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795329419" msec="75" />\n'
    '\t<content language=""></content>\n'
    "</message>\n"
)
R_E20_PING = (  # 07-errors.txt +34.207s conn 10
    '<message priority="2.0" timetolive="0.0">\n'
    "\t<type>PING</type>\n"
    "\t<id>3f715865-c21a-4b5b-ad00-412d9c639ecd</id>\n"
    "\t<from>RawClient</from>\n"
    "\t<to>CNS</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795329424" msec="80" />\n'
    '\t<content language=""></content>\n'
    "</message>\n"
)
R_E16_BARE = (  # 07-errors.txt +21.185s conn 7
    '<message priority="2.0" timetolive="0.0">\n'
    "\t<type>PING</type>\n"
    "\t<id>b38ba341-156d-4a88-b272-68173b273c82</id>\n"
    "\t<from>RawClient</from>\n"
    "\t<to>CNS</to>\n"
    "\t<cc></cc>\n"
    "\t<stored></stored>\n"
    "\t<isresponse></isresponse>\n"
    '\t<postedtime sec="1795329411" msec="59" />\n'
    '\t<content language=""></content>\n'
    "</message>\n"
)

# (literal, xmllen recorded in the transcript's frame line) — checked when the script runs.
RECORDED = {
    "J_BIND": (J_BIND, 288),
    "P_BIND_ACCEPT": (P_BIND_ACCEPT, 325),
    "J_RECEIVE_NAME": (J_RECEIVE_NAME, 306),
    "P_RESOLVE_SUCCESS": (P_RESOLVE_SUCCESS, 573),
    "J_GET_ENTRY_GLOBAL": (J_GET_ENTRY_GLOBAL, 302),
    "J_GET_ENTRY_READER": (J_GET_ENTRY_READER, 302),
    "P_ENTRY_GLOBAL": (P_ENTRY_GLOBAL, 619),
    "P_ENTRY_READER": (P_ENTRY_READER, 283),
    "R_E9_MINIMAL": (R_E9_MINIMAL, 39),
    "R_E11_MALFORMED": (R_E11_MALFORMED, 40),
    "R_E12_HELLO": (R_E12_HELLO, 11),
    "R_E13_GARBAGE": (R_E13_GARBAGE, 5),
    "R_E19_PING": (R_E19_PING, 290),
    "R_E20_PING": (R_E20_PING, 290),  # the header announced 570490880: the length big-endian
    "R_E16_BARE": (R_E16_BARE, 290),  # RAW 290 bytes, no header
}
