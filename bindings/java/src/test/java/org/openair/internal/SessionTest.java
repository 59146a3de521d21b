package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertFalse;
import static org.junit.jupiter.api.Assertions.assertInstanceOf;
import static org.junit.jupiter.api.Assertions.assertSame;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.util.ArrayList;
import java.util.List;
import java.util.Set;
import org.junit.jupiter.api.Nested;
import org.junit.jupiter.api.Test;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.RemoteProtocolException;

/** The sans-I/O session, with two ends joined back to back (h11's ConnectionPair). */
class SessionTest {
    static final long NOW = 1_795_328_371_396_250_000L;

    static Session requester() {
        return new Session(Session.Role.REQUESTER, () -> NOW, "Mod", 1 << 20, 1 << 20, 64);
    }

    static Session responder() {
        return new Session(Session.Role.RESPONDER, () -> NOW, "Mod", 1 << 20, 1 << 20, 64);
    }

    static List<Session.Event> bytewise(Session s, byte[] data) {
        List<Session.Event> events = new ArrayList<>();
        for (byte b : data) {
            events.addAll(s.receive(new byte[] {b}, 0, 1)); // OA-FRAME-11
        }
        return events;
    }

    static Message post(String id) {
        return Message.builder("Test.Ping.A").id(id).sender("Mod").to("WB1").build();
    }

    @Nested
    class Requester {
        @Test
        void stampsPostedTimeAndPairsRepliesInOrder() {
            Session client = requester();
            Session server = responder();
            client.window(2);
            List<Session.Event> got = new ArrayList<>();
            byte[] first = client.sendRequest(post("a"));
            got.addAll(server.receive(first, 0, first.length));
            assertEquals("1795328371", Long.toString(client.lastSent().posted().sec()));
            assertEquals(396, client.lastSent().posted().msec()); // OA-TIME-2
            byte[] second = client.sendRequest(post("b"));
            got.addAll(server.receive(second, 0, second.length));
            assertEquals(2, client.inFlight());
            assertFalse(client.canSend()); // OA-SESS-18: the window is full
            byte[] answers = concat(server.answer(got.get(0), null, ""),
                    server.answer(got.get(1), null, ""));
            List<Session.Event> replies = bytewise(client, answers);
            assertEquals("a", ((Session.Reply) replies.get(0)).requestId()); // OA-SESS-33
            assertEquals("b", ((Session.Reply) replies.get(1)).requestId());
            assertEquals("RECEIVE_ACCEPT", ((Session.Reply) replies.get(0)).message().type());
        }

        @Test
        void fullWindowIsMisuse() {
            Session client = requester();
            client.sendRequest(post("a"));
            assertThrows(ApiMisuseException.class, () -> client.sendRequest(post("b")));
        }

        @Test
        void noreplyNeedsTheExtensionAndTakesNoSlot() {
            Session client = requester();
            Message quiet = post("q").toBuilder().noreply(true).build();
            assertThrows(ApiMisuseException.class, () -> client.sendRequest(quiet)); // OA-GEN-2
            client.extensions(Set.of("noreply"));
            client.sendRequest(quiet);
            assertEquals(0, client.inFlight());
            assertTrue(client.canSend());
        }

        @Test
        void emptyIsresponseIsAccepted() {
            Session client = requester();
            client.sendRequest(Message.builder("KEEPALIVE").build());
            byte[] reply = encode(Message.builder("KEEPALIVESUCCESS").build());
            Session.Reply r = (Session.Reply) client.receive(reply, 0, reply.length).get(0);
            assertEquals(client.lastSent().id(), r.requestId()); // OA-SESS-33
        }

        @Test
        void replyNamingAnotherRequestIsStickyError() {
            Session client = requester();
            client.sendRequest(post("a"));
            byte[] reply = encode(Message.builder("RECEIVE_ACCEPT").isresponse("zzz").build());
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    () -> client.receive(reply, 0, reply.length));
            assertEquals(ErrorCode.MESSAGE_INVALID, e.code());
            assertSame(e, assertThrows(RemoteProtocolException.class,
                    () -> client.receive(new byte[0], 0, 0))); // OA-FRAME-9
            assertEquals(Session.State.ERROR, client.state());
            assertThrows(ConnectionClosedException.class, () -> client.sendRequest(post("c")));
        }

        @Test
        void replyWithoutRequestIsRefused() {
            Session client = requester();
            byte[] reply = encode(Message.builder("RECEIVE_ACCEPT").build());
            assertThrows(RemoteProtocolException.class, () -> client.receive(reply, 0, reply.length));
        }

        @Test
        void endInsideAFrameIsTruncated() {
            Session client = requester();
            client.sendRequest(post("a"));
            byte[] reply = encode(Message.builder("RECEIVE_ACCEPT").isresponse("a").build());
            client.receive(reply, 0, reply.length - 3);
            assertTrue(client.inFrame());
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    client::receiveEof);
            assertEquals(ErrorCode.FRAME_TRUNCATED, e.code()); // OA-FRAME-8
        }

        @Test
        void cleanEndListsTheUnansweredRequests() {
            Session client = requester();
            client.sendRequest(post("a"));
            Session.Closed closed = (Session.Closed) client.receiveEof().get(0);
            assertEquals(List.of("a"), closed.unanswered());
            assertThrows(ConnectionClosedException.class, () -> client.sendRequest(post("b")));
        }
    }

    @Nested
    class Responder {
        @Test
        void notificationTurnsTheConnectionAround() {
            Session cb = requester();
            byte[] frame = cb.sendNotification(Message.builder("RECEIVE_NAME_NOTIFICATION")
                    .sender("Mod").build());
            assertEquals("Receive", new String(frame, 0, 7)); // OA-FRAME-10, OA-SESS-7
            assertEquals(Session.State.RESPONDER, cb.state());
            assertThrows(ApiMisuseException.class, () -> cb.sendRequest(post("x"))); // OA-SESS-28
        }

        @Test
        void answersDefaultByTypeAndMustFollowArrivalOrder() {
            Session mod = responder();
            byte[] both = concat(encode(Message.builder("PING").id("p").build()),
                    encode(Message.builder("KEEPALIVE").id("k").build()));
            List<Session.Event> events = bytewise(mod, both);
            assertThrows(ApiMisuseException.class,
                    () -> mod.answer(events.get(1), null, "")); // OA-SESS-2
            Message ping = decodeFrame(mod.answer(events.get(0), null, ""));
            Message keep = decodeFrame(mod.answer(events.get(1), null, ""));
            assertEquals("PING_SUCCESS", ping.type()); // OA-SESS-11
            assertEquals("p", ping.isresponse());
            assertEquals("KEEPALIVESUCCESS", keep.type()); // OA-KEEP-2
            assertEquals("Mod", keep.sender());
        }

        @Test
        void malformedRequestIsInvalidAndTheConnectionStaysUsable() {
            Session mod = responder();
            byte[] bad = new Frame(Frame.Tag.MESSAGE, "<message><type>X".getBytes(), List.of())
                    .encode();
            Session.Event e = mod.receive(bad, 0, bad.length).get(0);
            assertInstanceOf(Session.Invalid.class, e);
            Message err = decodeFrame(mod.answer(e, null, ""));
            assertEquals("RECEIVE_ERROR", err.type());
            assertTrue(err.content().startsWith("XML_MALFORMED: "), err.content()); // OA-ERR-2
            byte[] ping = encode(Message.builder("PING").build());
            assertInstanceOf(Session.Request.class, mod.receive(ping, 0, ping.length).get(0));
        }

        @Test
        void framingErrorIsNotAnsweredButThrown() {
            Session mod = responder();
            byte[] junk = "GET / HTTP/1.1\r\n".getBytes();
            RemoteProtocolException e = assertThrows(RemoteProtocolException.class,
                    () -> mod.receive(junk, 0, junk.length));
            assertEquals(ErrorCode.FRAME_UNKNOWN_TAG, e.code()); // OA-FRAME-6
        }

        @Test
        void onlyLimitErrorsOfAResponderAreAnswered() {
            Session mod = responder();
            byte[] big = {'M', 'e', 's', 's', 'a', 'g', 'e', 0, (byte) 0xff, (byte) 0xff, 0x7f, 0};
            RemoteProtocolException tooLarge = assertThrows(RemoteProtocolException.class,
                    () -> mod.receive(big, 0, big.length));
            assertEquals(ErrorCode.FRAME_TOO_LARGE, tooLarge.code());
            Message reply = decodeFrame(mod.framingErrorReply(tooLarge)); // OA-FRAME-7
            assertEquals("RECEIVE_ERROR", reply.type());
            Session other = responder();
            byte[] junk = "Garbage\0\0\0\0\0".getBytes();
            RemoteProtocolException tag = assertThrows(RemoteProtocolException.class,
                    () -> other.receive(junk, 0, junk.length));
            assertEquals(null, other.framingErrorReply(tag)); // OA-FRAME-6: no reply
            Session client = requester();
            client.sendRequest(post("a"));
            RemoteProtocolException asClient = assertThrows(RemoteProtocolException.class,
                    () -> client.receive(big, 0, big.length));
            assertEquals(null, client.framingErrorReply(asClient)); // a requester never replies
        }

        @Test
        void noreplyDeliveryNeedsNoAnswerUnderTheExtension() {
            Session mod = responder();
            mod.extensions(Set.of("noreply"));
            byte[] quiet = encode(Message.builder("Chat").noreply(true).build());
            Session.Request r = (Session.Request) mod.receive(quiet, 0, quiet.length).get(0);
            assertFalse(r.needsAnswer()); // OA-MSG-15
            Session legacy = responder();
            Session.Request plain = (Session.Request) legacy.receive(quiet, 0, quiet.length).get(0);
            assertTrue(plain.needsAnswer());
        }
    }

    static byte[] encode(Message m) {
        return new Frame(Frame.Tag.MESSAGE, Codec.encode(m), List.of()).encode();
    }

    static Message decodeFrame(byte[] data) {
        FrameReader r = new FrameReader();
        r.feed(data);
        Frame f = r.next();
        return Codec.decode(f.xml());
    }

    static byte[] concat(byte[] a, byte[] b) {
        byte[] out = new byte[a.length + b.length];
        System.arraycopy(a, 0, out, 0, a.length);
        System.arraycopy(b, 0, out, a.length, b.length);
        return out;
    }
}
