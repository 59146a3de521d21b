# ruff: noqa: E501 (verbatim frames keep their long lines)
"""Real Psyclone 1.1.7 wakeups, copied verbatim (tabs and all) from the wire transcripts.

Each constant is the XML of one frame (frame header dropped); the comment names its origin.
"""

from __future__ import annotations

# psyclone-wire/03-post-wakeup.txt line 86: WB1 wakes Reader for Test.Ping.A.
PSYCLONE_TRIGGER_WAKEUP = """<message>
	<type>AIR.Instruct.Wakeup</type>
	<id>cc549432-7306-411d-882c-7539cb8623fa</id>
	<from>WB1</from>
	<to>Reader</to>
	<cc></cc>
	<stored>WB1</stored>
	<isresponse></isresponse>
	<postedTime  sec="1795328371" msec="662" tzc="Greenwich_0_60" />
	<content language="xml">
		<objectdictionary>
			<object name="TriggerMessage">
				<message priority="2.00">
					<type>Test.Ping.A</type>
					<id>e5d1dae0-b5c8-4cbf-b65f-f1e8c87fd86c</id>
					<from>Poster</from>
					<to>WB1</to>
					<cc></cc>
					<stored>WB1</stored>
					<isresponse></isresponse>
					<netprotocol>Message</netprotocol>
					<postedTime  sec="1795328371" msec="396" tzc="Greenwich_0_60" />
					<receivedTime  sec="1795328371" msec="444" tzc="Greenwich_0_60" />
					<content language="">hello ping</content>
				</message>
			</object>
			<object name="RetrievedMessages">
				<objectcollection />
			</object>
			<object name="PhaseSpec">
				<phase name="Default Phase" module="Reader" context="Psyclone.System.Ready" lasttrigger="Test.Ping.*" pid="9d68f3bf-cc33-4565-92f0-eef1a850eae6" priority="1.000">
					<triggers>
						<trigger after="0" from="WB1" type="Test.Ping.*" />
					</triggers>
					<currentcontexts>
						<objectdictionary>
							<object name="Psyclone.System.Ready">
								<time  sec="1795328160" msec="836" tzc="Greenwich_0_60" />
							</object>
						</objectdictionary>
					</currentcontexts>
					<activationtime  sec="1795328370" msec="875" tzc="Greenwich_0_60" />
				</phase>
			</object>
		</objectdictionary>
	</content>
</message>"""

# psyclone-wire/02-subscribe.txt line 62: ContextsAndPhases' phase update after AIR.Subscribe.
PSYCLONE_PHASE_UPDATE = """<message>
	<type>AIR.Instruct.Wakeup</type>
	<id>0b65dd0f-4b5a-4b18-abdd-980e600713bb</id>
	<from>ContextsAndPhases</from>
	<to>Reader</to>
	<cc></cc>
	<stored></stored>
	<isresponse></isresponse>
	<postedTime  sec="1795328371" msec="83" tzc="Greenwich_0_60" />
	<content language="xml">
		<objectdictionary>
			<object name="PhaseSpec">
				<phase name="Default Phase" module="Reader" context="Psyclone.System.Ready" lasttrigger="" pid="9d68f3bf-cc33-4565-92f0-eef1a850eae6" priority="1.000">
					<triggers>
						<trigger after="0" from="WB1" type="Test.Ping.*" />
					</triggers>
					<activationtime  sec="1795328370" msec="875" tzc="Greenwich_0_60" />
				</phase>
			</object>
		</objectdictionary>
	</content>
</message>"""

# psyclone-wire/05-retrieve.txt line 3466 (Part D): N1's wakeup with two retrieved messages.
PSYCLONE_RETRIEVED_WAKEUP = """<message>
	<type>AIR.Instruct.Wakeup</type>
	<id>5ecbbd20-0128-404f-b2e2-07591b41e537</id>
	<from>WB1</from>
	<to>N1</to>
	<cc></cc>
	<stored>WB1</stored>
	<isresponse></isresponse>
	<postedTime  sec="1795330134" msec="112" tzc="Greenwich_0_60" />
	<content language="xml">
		<objectdictionary>
			<object name="TriggerMessage">
				<message priority="2.00">
					<type>TR.Go</type>
					<id>c587cf65-8293-461e-9d95-3de18eb22e13</id>
					<from>Poster</from>
					<to>WB1</to>
					<cc></cc>
					<stored>WB1</stored>
					<isresponse></isresponse>
					<netprotocol>Message</netprotocol>
					<postedTime  sec="1795330133" msec="794" tzc="Greenwich_0_60" />
					<receivedTime  sec="1795330133" msec="829" tzc="Greenwich_0_60" />
					<content language="">probe TR.Go cc=</content>
				</message>
			</object>
			<object name="RetrievedMessages">
				<objectcollection>
					<object>
						<message priority="2.00">
							<type>TR.Data.3</type>
							<id>05356e61-dbff-4f80-948a-484373c88015</id>
							<from>Poster</from>
							<to>WB1</to>
							<cc></cc>
							<stored>WB1</stored>
							<isresponse></isresponse>
							<netprotocol>Message</netprotocol>
							<wbid>00000003</wbid>
							<postedTime  sec="1795330133" msec="757" tzc="Greenwich_0_60" />
							<receivedTime  sec="1795330133" msec="794" tzc="Greenwich_0_60" />
							<content language="">probe TR.Data.3 cc=</content>
						</message>
					</object>
					<object>
						<message priority="2.00">
							<type>TR.Data.2</type>
							<id>090a5962-dc2e-4cbe-8313-267b62674b0a</id>
							<from>Poster</from>
							<to>WB1</to>
							<cc></cc>
							<stored>WB1</stored>
							<isresponse></isresponse>
							<netprotocol>Message</netprotocol>
							<wbid>00000002</wbid>
							<postedTime  sec="1795330133" msec="717" tzc="Greenwich_0_60" />
							<receivedTime  sec="1795330133" msec="747" tzc="Greenwich_0_60" />
							<content language="">probe TR.Data.2 cc=</content>
						</message>
					</object>
				</objectcollection>
			</object>
			<object name="PhaseSpec">
				<phase name="Default" module="N1" context="Psyclone.System.Ready" lasttrigger="TR.Go" pid="1dc82c02-aa56-4ff6-8e21-be26e576083b" priority="0.000">
					<triggers>
						<trigger after="0" from="WB1" type="TR.Go" />
					</triggers>
					<retrieves>
						<retrieve from="WB1" sender="" type="TR.Data.*" id="" content="" contentmatch="">
							<latest>2</latest>
						</retrieve>
					</retrieves>
					<currentcontexts>
						<objectdictionary>
							<object name="Psyclone.System.Ready">
								<time  sec="1795330126" msec="764" tzc="Greenwich_0_60" />
							</object>
						</objectdictionary>
					</currentcontexts>
					<activationtime  sec="1795330129" msec="554" tzc="Greenwich_0_60" />
				</phase>
			</object>
		</objectdictionary>
	</content>
</message>"""

# psyclone-wire/04-cc.txt line 59: a wakeup due only to cc (lasttrigger empty).
PSYCLONE_CC_WAKEUP = """<message>
	<type>AIR.Instruct.Wakeup</type>
	<id>63c8e50a-abb8-4e31-9551-fa87a5d38b4b</id>
	<from>WB1</from>
	<to>Reader</to>
	<cc></cc>
	<stored>WB1</stored>
	<isresponse></isresponse>
	<postedTime  sec="1795328372" msec="16" tzc="Greenwich_0_60" />
	<content language="xml">
		<objectdictionary>
			<object name="TriggerMessage">
				<message priority="2.00">
					<type>Other.Unsubscribed.Type</type>
					<id>3473ffd9-891c-4a30-a293-8c9af54ed4f3</id>
					<from>Poster</from>
					<to>WB1</to>
					<cc>Reader</cc>
					<stored>WB1</stored>
					<isresponse></isresponse>
					<comment>CC&apos;ed to Reader</comment>
					<netprotocol>Message</netprotocol>
					<postedTime  sec="1795328371" msec="987" tzc="Greenwich_0_60" />
					<receivedTime  sec="1795328372" msec="10" tzc="Greenwich_0_60" />
					<content language="">cc test</content>
				</message>
			</object>
			<object name="RetrievedMessages">
				<objectcollection />
			</object>
			<object name="PhaseSpec">
				<phase name="Default Phase" module="Reader" context="Psyclone.System.Ready" lasttrigger="" pid="9d68f3bf-cc33-4565-92f0-eef1a850eae6" priority="1.000">
					<triggers>
						<trigger after="0" from="WB1" type="Test.Ping.*" />
					</triggers>
					<activationtime  sec="1795328370" msec="875" tzc="Greenwich_0_60" />
				</phase>
			</object>
		</objectdictionary>
	</content>
</message>"""
