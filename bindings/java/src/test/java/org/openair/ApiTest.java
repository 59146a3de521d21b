package org.openair;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertNotEquals;
import static org.junit.jupiter.api.Assertions.assertNotSame;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.time.Duration;
import java.util.ArrayList;
import java.util.List;
import java.util.Optional;
import java.util.Set;
import org.junit.jupiter.api.Nested;
import org.junit.jupiter.api.Test;

/** The public value types: immutability, defensive copies, validation. */
class ApiTest {
    @Nested
    class Messages {
        @Test
        void binaryChunksAreCopiedInAndOut() {
            byte[] chunk = {1, 2, 3};
            Message m = Message.builder("A").binary(List.of(chunk)).build();
            chunk[0] = 9;
            assertEquals(1, m.binary().get(0)[0]);
            m.binary().get(0)[0] = 7;
            assertEquals(1, m.binary().get(0)[0]);
            assertNotSame(m.binary().get(0), m.binary().get(0));
        }

        @Test
        void listsAreImmutableCopies() {
            List<Slot> slots = new ArrayList<>(List.of(Slot.text("x", "1")));
            Message m = Message.builder("A").extras(slots).build();
            slots.clear();
            assertEquals(1, m.extras().size());
            assertThrows(UnsupportedOperationException.class, () -> m.extras().clear());
        }

        @Test
        void equalityComparesChunkContents() {
            Message a = Message.builder("A").id("1").binary(List.of(new byte[] {1})).build();
            Message b = Message.builder("A").id("1").binary(List.of(new byte[] {1})).build();
            assertEquals(a, b);
            assertEquals(a.hashCode(), b.hashCode());
            assertNotEquals(a, a.toBuilder().binary(List.of(new byte[] {2})).build());
        }

        @Test
        void priorityRangeIsChecked() {
            assertThrows(ApiMisuseException.class,
                    () -> Message.builder("A").priority(7.0).build()); // OA-MSG-6
            assertEquals(2.0, Message.builder("A").build().effectivePriority());
        }

        @Test
        void ccNamesAreSplitOnSemicolons() {
            Message m = Message.builder("A").cc(" A ; ;B,C;").build();
            assertEquals(List.of("A", "B,C"), m.ccNames()); // OA-CC-1
        }

        @Test
        void freshIdsAreUuids() {
            assertEquals(36, Message.builder("A").build().id().length()); // OA-MSG-8
            assertNotEquals(Message.builder("A").build().id(), Message.builder("A").build().id());
        }

        @Test
        void contentKindFollowsTheLastSetter() {
            Message xml = Message.builder("A").xmlContent("<a/>").build();
            assertTrue(xml.contentIsXml());
            assertEquals("xml", xml.language());
            Message text = xml.toBuilder().content("t").build();
            assertEquals("", text.language());
        }
    }

    @Nested
    class Values {
        @Test
        void timesFromNanos() {
            AirTime t = AirTime.ofEpochNanos(1_795_328_371_396_250_999L, true);
            assertEquals(new AirTime(1_795_328_371L, 396, 250), t);
            assertEquals(AirTime.of(-1, 999), AirTime.ofEpochMillis(-1));
            assertThrows(IllegalArgumentException.class, () -> AirTime.of(0, 1000));
        }

        @Test
        void failedRequestNamesItsCondition() {
            Message req = Message.builder("A").build();
            Message rep = Message.builder("RECEIVE_ERROR").content("TYPE_INVALID: star").build();
            RequestFailedException e = new RequestFailedException(req, rep);
            assertEquals(Optional.of(ErrorCode.TYPE_INVALID), e.condition());
            assertEquals(ErrorCode.REQUEST_FAILED, e.code());
            assertThrows(IllegalArgumentException.class,
                    () -> new PeerException(ErrorCode.XML_MALFORMED, "")); // blame is checked
        }

        @Test
        void capabilitiesKeepLimits() {
            Capabilities c = new Capabilities("OpenAIR/1.0", "s", List.of("noreply"),
                    java.util.Map.of("max-in-flight", 4L));
            assertEquals(4L, c.limit("max-in-flight").getAsLong());
            assertTrue(c.limit("nope").isEmpty());
        }
    }

    @Nested
    class OptionsBuilder {
        @Test
        void defaultsFollowTheSpec() {
            Options o = Options.builder("M").build();
            assertEquals(10000, o.port());
            assertEquals(Duration.ofSeconds(10), o.requestTimeout()); // OA-SESS-27
            assertEquals(Duration.ofSeconds(60), o.keepalive()); // OA-KEEP-1
            assertEquals(16L * 1024 * 1024, o.maxFrameXml()); // OA-LIM-1
            assertEquals(64, o.maxXmlDepth()); // OA-LIM-3
            assertEquals(Options.SUPPORTED_EXTENSIONS, o.extensions());
        }

        @Test
        void impossibleCombinationsAreMisuse() {
            assertThrows(ApiMisuseException.class, () -> Options.builder("M").listen(false)
                    .callback(false).build()); // OA-DELIV-10
            assertThrows(ApiMisuseException.class, () -> Options.builder("").build());
            assertThrows(ApiMisuseException.class,
                    () -> Options.builder("M").extensions(Set.of("auth")).build()); // OA-EXT-4
            assertThrows(ApiMisuseException.class, () -> Options.builder("M").port(0).build());
            assertThrows(ApiMisuseException.class,
                    () -> Options.builder("M").requestTimeout(Duration.ZERO).build());
        }

        @Test
        void aPlainClientNeedsNoName() {
            assertEquals("", Options.builder("").bind(false).build().name());
        }

        @Test
        void toBuilderRoundTrips() {
            Options o = Options.builder("M").server("h", 1234).listenPort(5).build();
            assertEquals(o, o.toBuilder().build());
        }
    }
}
