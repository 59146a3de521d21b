package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertFalse;
import static org.junit.jupiter.api.Assertions.assertNotNull;
import static org.junit.jupiter.api.Assertions.assertNull;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.io.IOException;
import java.io.InputStream;
import java.net.InetAddress;
import java.net.ServerSocket;
import java.net.Socket;
import java.time.Duration;
import java.util.ArrayList;
import java.util.Arrays;
import java.util.List;
import java.util.Optional;
import java.util.Set;
import java.util.concurrent.BlockingQueue;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.TimeUnit;
import java.util.concurrent.atomic.AtomicInteger;
import org.junit.jupiter.api.AfterEach;
import org.junit.jupiter.api.BeforeEach;
import org.junit.jupiter.api.Nested;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.api.Timeout;
import org.openair.ApiMisuseException;
import org.openair.ConnectionClosedException;
import org.openair.ConnectionListener;
import org.openair.DeliveryPath;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.OpenAirException;
import org.openair.Options;
import org.openair.Registration;
import org.openair.RequestFailedException;
import org.openair.RequestTimeoutException;
import org.openair.RetrieveSpec;
import org.openair.Trigger;
import org.openair.Wakeup;

/** The client against a scripted server ({@link FakeServer}): one nested class per behaviour. */
@Timeout(value = 20, unit = TimeUnit.SECONDS)
class ModuleTest {
    static final Duration WAIT = Duration.ofSeconds(5);
    static final String WAKEUP_CONTENT = "<objectdictionary>"
            + "<object name=\"TriggerMessage\"><message priority=\"2.0\"><type>Test.Ping.A</type>"
            + "<id>t-1</id><from>Poster</from><to>WB1</to><stored>WB1</stored>"
            + "<postedTime sec=\"1\" msec=\"2\"/><receivedTime sec=\"1\" msec=\"3\"/>"
            + "<wbid>00000007</wbid><content language=\"\">hi</content></message></object>"
            + "<object name=\"RetrievedMessages\"><objectcollection><object><message>"
            + "<type>R.One</type><id>r-1</id></message></object></objectcollection></object>"
            + "<object name=\"PhaseSpec\"><phase name=\"Default\" module=\"JTest\" "
            + "context=\"Psyclone.System.Ready\" lasttrigger=\"Test.Ping.*\"><triggers>"
            + "<trigger after=\"0\" from=\"WB1\" type=\"Test.Ping.*\"/></triggers></phase></object>"
            + "</objectdictionary>";

    FakeServer fake;
    Module module;
    final BlockingQueue<Integer> connected = new LinkedBlockingQueue<>();
    final BlockingQueue<Throwable> errors = new LinkedBlockingQueue<>();
    final BlockingQueue<String> disconnected = new LinkedBlockingQueue<>();

    @BeforeEach
    void start() throws IOException {
        fake = new FakeServer();
    }

    @AfterEach
    void stop() throws IOException {
        if (module != null) {
            module.close();
        }
        fake.close();
    }

    Options.Builder options() {
        return Options.builder("JTest").server("127.0.0.1", fake.port()).listen(false)
                .requestTimeout(Duration.ofSeconds(3)).reconnectDelay(Duration.ofMillis(20))
                .keepalive(Duration.ZERO)
                .connectionListener(new ConnectionListener() {
                    @Override
                    public void onConnected(int generation) {
                        connected.add(generation);
                    }

                    @Override
                    public void onDisconnected(OpenAirException cause) {
                        disconnected.add(String.valueOf(cause));
                    }

                    @Override
                    public void onError(Throwable error) {
                        errors.add(error);
                    }
                });
    }

    Module connect(Options.Builder b) {
        module = OpenAir.connect(b.build());
        return module;
    }

    static Message wakeup(String content) {
        return Message.builder("AIR.Instruct.Wakeup").sender("WB1").to("JTest").stored("WB1")
                .xmlContent(content).build();
    }

    void awaitGeneration(int generation) throws InterruptedException {
        while (true) {
            Integer g = connected.poll(WAIT.toMillis(), TimeUnit.MILLISECONDS);
            assertNotNull(g, "no (re)connection");
            if (g >= generation) {
                return;
            }
        }
    }

    @Nested
    class Connecting {
        @Test
        void modernServerGetsTheAdvertisedExtensionsDeclared() throws Exception {
            connect(options());
            assertFalse(module.legacy());
            assertEquals(Set.of("noreply", "pipelining", "usec"), module.extensions());
            assertEquals("fake", module.capabilities().orElseThrow().server());
            assertEquals(-1, module.boundPort());
            FakeServer.Received first = fake.received.take();
            assertEquals("GET_CAPABILITIES", first.message().type()); // OA-CAP-2: asked first
            Message bind = fake.find("BIND_NOLISTEN", WAIT).message();
            assertEquals("noreply pipelining usec", bind.extra("extensions").value()); // OA-SESS-19
            FakeServer.Received note = fake.find("RECEIVE_NAME_NOTIFICATION", WAIT);
            assertEquals(Frame.Tag.RECEIVE, note.tag()); // OA-SESS-7
            assertEquals("JTest", note.message().sender());
            assertNotNull(fake.find("Psyclone.Module.Connect.JTest", WAIT).message().posted());
            awaitGeneration(1);
        }

        @Test
        void onlyTheOfferedExtensionsAreDeclared() throws Exception {
            connect(options().extensions(Set.of("noreply")));
            assertEquals(Set.of("noreply"), module.extensions());
            assertEquals("noreply",
                    fake.next("BIND_NOLISTEN", WAIT).message().extra("extensions").value());
        }

        @Test
        void legacyServerSeesNoExtension() throws Exception {
            fake.legacy = true;
            connect(options());
            assertTrue(module.legacy());
            assertTrue(module.extensions().isEmpty());
            assertNull(fake.find("BIND_NOLISTEN", WAIT).message().extra("extensions")); // OA-GEN-2
            assertNull(fake.find("RECEIVE_NAME_NOTIFICATION", WAIT).message().extra("extensions"));
            module.postNoReply(Message.builder("Test.Plain").to("WB1").build());
            Message plain = fake.next("Test.Plain", WAIT).message();
            assertFalse(plain.noreply()); // OA-GEN-2: posted plainly
            assertNull(plain.posted().usec()); // OA-TIME-5: no usec towards a legacy server
            module.post("WB1", "Test.After", "x"); // the plain post's reply was read and dropped
        }

        @Test
        void bindErrorFailsTheConnect() {
            fake.behaviours.put("BIND_NOLISTEN", (c, req) ->
                    c.send(FakeServer.reply(req, "BIND_ERROR", "BIND_REFUSED: name taken")));
            RequestFailedException e = assertThrows(RequestFailedException.class,
                    () -> connect(options()));
            assertEquals(Optional.of(ErrorCode.BIND_REFUSED), e.condition());
            assertEquals("BIND_ERROR", e.reply().type());
        }

        @Test
        void unreachableServerIsConnectionClosed() throws IOException {
            int port;
            try (ServerSocket s = new ServerSocket(0)) {
                port = s.getLocalPort();
            }
            assertThrows(ConnectionClosedException.class,
                    () -> OpenAir.connect(options().port(port).build()));
        }

        @Test
        void bindAsksForTheConfiguredPort() throws Exception {
            int free = freePort();
            fake.bindPort = free;
            connect(options().listen(true).listenPort(free).callback(false));
            Message bind = fake.next("BIND", WAIT).message();
            assertTrue(bind.contentIsXml());
            assertEquals("<tcplocation port=\"" + free + "\"/>", bind.content()); // OA-SESS-4
            assertEquals(free, module.boundPort());
            assertEquals(free, module.listenPort());
        }
    }

    @Nested
    class Posting {
        @BeforeEach
        void up() {
            connect(options());
        }

        @Test
        void postReturnsTheMessageAsSent() throws Exception {
            Message sent = module.post("WB1", "Test.Ping.A", "hello & <bye>");
            Message got = fake.next("Test.Ping.A", WAIT).message();
            assertEquals(sent.id(), got.id());
            assertEquals("JTest", got.sender());
            assertEquals("hello & <bye>", got.content());
            assertEquals(sent.posted(), got.posted()); // OA-TIME-2: stamped when sent
            assertNotNull(got.posted().usec()); // OA-TIME-5: usec agreed
        }

        @Test
        void failureReplyIsRequestFailedWithItsCondition() {
            fake.behaviours.put("Test.Fail", (c, req) ->
                    c.send(FakeServer.reply(req, "RECEIVE_ERROR", "STORE_FAILED: disk full")));
            RequestFailedException e = assertThrows(RequestFailedException.class,
                    () -> module.post("WB1", "Test.Fail", ""));
            assertEquals(ErrorCode.REQUEST_FAILED, e.code());
            assertEquals(Optional.of(ErrorCode.STORE_FAILED), e.condition()); // OA-ERR-2
            assertEquals("Test.Fail", e.request().type());
        }

        @Test
        void failureWithoutAKnownConditionKeepsTheContent() {
            fake.behaviours.put("Test.Odd", (c, req) ->
                    c.send(FakeServer.reply(req, "RECEIVE_ERROR", "API_MISUSE: not on the wire")));
            RequestFailedException e = assertThrows(RequestFailedException.class,
                    () -> module.post("WB1", "Test.Odd", ""));
            assertEquals(Optional.empty(), e.condition()); // OA-ERR-7, OA-ERR-8
            assertEquals("API_MISUSE: not on the wire", e.reply().content());
        }

        @Test
        void invalidTypeIsRefusedBeforeSending() {
            assertThrows(ApiMisuseException.class, () -> module.post("WB1", "Bad..Type", ""));
            assertThrows(ApiMisuseException.class, () -> module.post("WB1", "Star*", ""));
        }

        @Test
        void noreplyPostCarriesTheAttributeAndGetsNoReply() throws Exception {
            Message sent = module.postNoReply(Message.builder("Test.Fast").to("WB1").build());
            Message got = fake.next("Test.Fast", WAIT).message();
            assertTrue(got.noreply()); // OA-MSG-15
            assertEquals(sent.id(), got.id());
            module.post("WB1", "Test.Next", ""); // the session is still in step
        }

        @Test
        void postAllIsPipelinedWhenAdvertised() {
            List<FakeServer.Conn> held = new ArrayList<>();
            List<Message> requests = new ArrayList<>();
            fake.behaviours.put("Test.Pipe", (c, req) -> { // answers only once all 3 arrived
                synchronized (held) {
                    held.add(c);
                    requests.add(req);
                    if (requests.size() == 3) {
                        for (int i = 0; i < 3; i++) {
                            held.get(i).send(FakeServer.reply(requests.get(i), "RECEIVE_ACCEPT", ""));
                        }
                    }
                }
            });
            List<Message> batch = List.of(Message.builder("Test.Pipe").to("WB1").build(),
                    Message.builder("Test.Pipe").to("WB1").build(),
                    Message.builder("Test.Pipe").to("WB1").build());
            List<Message> sent = module.postAll(batch); // OA-SESS-17
            assertEquals(3, sent.size());
            assertEquals(batch.get(2).id(), sent.get(2).id());
        }

        @Test
        void postAsyncCompletesWithTheSentMessage() throws Exception {
            Message sent = module.postAsync(Message.builder("Test.Async").to("WB1").build())
                    .get(5, TimeUnit.SECONDS);
            assertEquals(sent.id(), fake.next("Test.Async", WAIT).message().id());
        }

        @Test
        void subscribeSendsTheModuleForm() throws Exception {
            module.subscribe(new Registration(
                    List.of(new Trigger("Test.*", "WB1", 0), Trigger.on("X.Y"),
                            new Trigger("Z", "", 250)),
                    List.of(RetrieveSpec.of("WB1", "T.*", 2)), true));
            Message reg = fake.next("AIR.Subscribe", WAIT).message();
            assertEquals("AIRCentral", reg.to());
            assertEquals("<module name=\"JTest\" allowselftriggering=\"yes\"><triggers>"
                    + "<trigger type=\"Test.*\" from=\"WB1\"/><trigger type=\"X.Y\"/>"
                    + "<trigger type=\"Z\" after=\"250\"/></triggers><retrieves>"
                    + "<retrieve from=\"WB1\" type=\"T.*\"><latest>2</latest></retrieve>"
                    + "</retrieves></module>", reg.content());
        }

        @Test
        void invalidPatternIsRefusedBeforeSending() {
            assertThrows(ApiMisuseException.class,
                    () -> module.subscribe(Registration.of(Trigger.on("A.**"))));
        }

        @Test
        void retrieveReadsTheCollection() throws Exception {
            fake.behaviours.put("AIR.Retrieve", (c, req) -> c.send(Message.builder(
                    "AIR.Retrieve.Success").sender("AIRCentral").to(req.sender())
                    .isresponse(req.id()).xmlContent("<objectcollection><object><message>"
                            + "<type>T.B</type><id>b</id><wbid>00000002</wbid></message></object>"
                            + "<object><message><type>T.A</type><id>a</id><wbid>1</wbid>"
                            + "</message></object></objectcollection>").build()));
            List<Message> got = module.retrieve(RetrieveSpec.of("WB1", "T.*", 2));
            assertEquals(List.of("b", "a"), got.stream().map(Message::id).toList());
            assertEquals(2L, got.get(0).wbid());
            assertEquals("<retrieve from=\"WB1\" type=\"T.*\"><latest>2</latest></retrieve>",
                    fake.next("AIR.Retrieve", WAIT).message().content());
        }

        @Test
        void retrieveFailureIsRequestFailed() {
            fake.behaviours.put("AIR.Retrieve", (c, req) -> c.send(FakeServer.reply(req,
                    "AIR.Retrieve.Failed", "WHITEBOARD_UNKNOWN: NoSuchWB")));
            RequestFailedException e = assertThrows(RequestFailedException.class,
                    () -> module.retrieve(RetrieveSpec.of("NoSuchWB", "*", 1)));
            assertEquals(Optional.of(ErrorCode.WHITEBOARD_UNKNOWN), e.condition());
        }

        @Test
        void pingMeasuresARoundTrip() {
            assertFalse(module.ping().isNegative());
        }
    }

    @Nested
    class OneAtATime {
        @Test
        void legacyServerNeverHasTwoRequestsInFlight() {
            fake.legacy = true;
            connect(options());
            AtomicInteger pending = new AtomicInteger();
            AtomicInteger peak = new AtomicInteger();
            fake.behaviours.put("Test.Seq", (c, req) -> {
                peak.accumulateAndGet(pending.incrementAndGet(), Math::max);
                Thread t = new Thread(() -> {
                    try {
                        Thread.sleep(30); // leave room for a second request, were it sent
                        pending.decrementAndGet();
                        c.send(FakeServer.reply(req, "RECEIVE_ACCEPT", ""));
                    } catch (IOException | InterruptedException e) {
                        throw new IllegalStateException(e);
                    }
                });
                t.start();
            });
            List<Message> batch = new ArrayList<>();
            for (int i = 0; i < 4; i++) {
                batch.add(Message.builder("Test.Seq").to("WB1").build());
            }
            assertEquals(4, module.postAll(batch).size());
            assertEquals(1, peak.get()); // OA-SESS-18
        }
    }

    @Nested
    class MisbehavingServer {
        @Test
        void silenceTimesOutClosesAndReconnectsWithTheRegistration() throws Exception {
            connect(options().requestTimeout(Duration.ofMillis(400)));
            module.subscribe(Registration.of(Trigger.on("Test.*")));
            fake.behaviours.put("Test.Silent", (c, req) -> { });
            assertThrows(RequestTimeoutException.class, () -> module.post("WB1", "Test.Silent", ""));
            awaitGeneration(2); // OA-SESS-27: the connection was closed and made anew
            fake.next("Psyclone.Module.Reconnect.JTest", WAIT);
            assertEquals(2, fake.count("AIR.Subscribe")); // re-sent before the notice
            module.post("WB1", "Test.After", "");
        }

        @Test
        void closeInsideAReplyIsConnectionClosed() throws Exception {
            connect(options());
            fake.behaviours.put("Test.Cut", (c, req) -> {
                byte[] frame = new Frame(Frame.Tag.MESSAGE, Codec.encode(FakeServer.reply(req,
                        "RECEIVE_ACCEPT", "")), List.of()).encode();
                c.sendRaw(Arrays.copyOf(frame, frame.length / 2));
                c.close();
            });
            assertThrows(ConnectionClosedException.class,
                    () -> module.post("WB1", "Test.Cut", "")); // OA-FRAME-8
            awaitGeneration(2);
            module.post("WB1", "Test.After", "");
        }

        @Test
        void malformedReplyFailsTheRequest() throws Exception {
            connect(options());
            fake.behaviours.put("Test.Bad", (c, req) -> c.sendXml("<message><type>RECEIVE_"));
            assertThrows(OpenAirException.class, () -> module.post("WB1", "Test.Bad", ""));
            awaitGeneration(2);
            module.post("WB1", "Test.After", "");
        }

        @Test
        void replyForAnotherRequestIsRefused() throws Exception {
            connect(options());
            fake.behaviours.put("Test.Swap", (c, req) -> c.send(Message.builder("RECEIVE_ACCEPT")
                    .sender("WB1").isresponse("not-" + req.id()).build()));
            assertThrows(OpenAirException.class, () -> module.post("WB1", "Test.Swap", ""));
            awaitGeneration(2); // OA-SESS-2, OA-SESS-33: the pairing is lost, so is the link
        }

        @Test
        void unknownFrameTagClosesTheConnection() throws Exception {
            connect(options());
            fake.behaviours.put("Test.Http", (c, req) ->
                    c.sendRaw("HTTP/1.1 200 OK\r\n\r\n".getBytes()));
            assertThrows(ConnectionClosedException.class,
                    () -> module.post("WB1", "Test.Http", "")); // OA-FRAME-6
            awaitGeneration(2);
        }

        @Test
        void lostServerIsReconnectedAndReregistered() throws Exception {
            connect(options());
            module.subscribe(Registration.of(Trigger.on("Test.*")));
            fake.next("AIR.Subscribe", WAIT);
            fake.dropConnections();
            awaitGeneration(2);
            fake.next("AIR.Subscribe", WAIT); // re-sent on the new connection
            assertEquals(2, module.generation());
        }

        @Test
        void withoutReconnectALostConnectionStaysLost() throws Exception {
            connect(options().reconnect(false));
            fake.dropConnections();
            assertNotNull(disconnected.poll(5, TimeUnit.SECONDS));
            assertFalse(module.isConnected());
            assertThrows(ConnectionClosedException.class, () -> module.ping());
        }
    }

    @Nested
    class Deliveries {
        final BlockingQueue<Wakeup> woken = new LinkedBlockingQueue<>();
        final BlockingQueue<String> threads = new LinkedBlockingQueue<>();

        Module withListener() {
            return connect(options().wakeupListener(w -> {
                threads.add(Thread.currentThread().getName());
                woken.add(w);
            }));
        }

        @Test
        void wakeupIsAcknowledgedAndDispatchedOnTheDispatcherThread() throws Exception {
            withListener();
            Message w = wakeup(WAKEUP_CONTENT);
            Message ack = fake.callback(WAIT).deliver(w, WAIT);
            assertEquals("RECEIVE_ACCEPT", ack.type()); // OA-DELIV-4
            assertEquals(w.id(), ack.isresponse());
            assertEquals("JTest", ack.sender());
            assertNotNull(ack.posted());
            Wakeup got = woken.poll(5, TimeUnit.SECONDS);
            assertNotNull(got);
            assertEquals("openair-JTest-dispatch", threads.take());
            assertEquals("Test.Ping.A", got.trigger().type());
            assertEquals(7L, got.trigger().wbid());
            assertEquals(List.of("R.One"), got.retrieved().stream().map(Message::type).toList());
            assertEquals("Test.Ping.*", got.lasttrigger());
            assertEquals("Default", got.phase());
            assertEquals(DeliveryPath.CALLBACK, got.path());
            assertFalse(got.isPhaseUpdate());
        }

        @Test
        void pingAndKeepaliveAreAnswered() throws Exception {
            connect(options());
            FakeServer.Conn cb = fake.callback(WAIT);
            Message ping = Message.builder("PING").sender("CNS").to("JTest").build();
            assertEquals("PING_SUCCESS", cb.deliver(ping, WAIT).type()); // OA-SESS-11
            Message keep = Message.builder("KEEPALIVE").build();
            assertEquals("KEEPALIVESUCCESS", cb.deliver(keep, WAIT).type()); // OA-KEEP-2
        }

        @Test
        void malformedDeliveryIsAnsweredAndTheConnectionStaysUsable() throws Exception {
            connect(options());
            FakeServer.Conn cb = fake.callback(WAIT);
            cb.sendXml("<message><type>Broken</type"); // OA-ERR-3
            Message err = cb.replies.poll(5, TimeUnit.SECONDS);
            assertNotNull(err);
            assertEquals("RECEIVE_ERROR", err.type());
            assertTrue(err.content().startsWith("XML_MALFORMED"), err.content()); // OA-ERR-2
            Message ping = Message.builder("PING").build();
            assertEquals("PING_SUCCESS", cb.deliver(ping, WAIT).type());
        }

        @Test
        void unreadableDeliveriesAreCountedAndReported() throws Exception {
            connect(options());
            FakeServer.Conn cb = fake.callback(WAIT);
            String barrier = new String(Vectors.bytes("legacy", "psy2-cc003-barrier-wakeup.xml"),
                    java.nio.charset.StandardCharsets.UTF_8);
            cb.sendXml(barrier); // Psyclone's priority="7.00" is read (OA-MSG-19)
            assertEquals("RECEIVE_ACCEPT", cb.replies.poll(5, TimeUnit.SECONDS).type());
            cb.sendXml(barrier.replace("priority=\"7.00\"", "priority=\"high\""));
            assertEquals("RECEIVE_ERROR", cb.replies.poll(5, TimeUnit.SECONDS).type());
            cb.sendXml("<message><type>Broken</type"); // OA-ERR-3: the connection stays
            assertEquals("RECEIVE_ERROR", cb.replies.poll(5, TimeUnit.SECONDS).type());
            assertEquals(2L, module.undecodableDeliveries()); // OA-MSG-20
            assertEquals(2L, module.droppedMessages());
            Throwable first = errors.poll(5, TimeUnit.SECONDS);
            Throwable second = errors.poll(5, TimeUnit.SECONDS);
            assertTrue(first instanceof OpenAirException e && e.code() == ErrorCode.CONTENT_INVALID
                    && e.getMessage().contains("priority"), String.valueOf(first));
            assertTrue(second instanceof OpenAirException e && e.code() == ErrorCode.XML_MALFORMED,
                    String.valueOf(second));
            Wakeup w = module.nextWakeup(WAIT).orElseThrow();
            assertEquals(6.999, w.trigger().priority(), 0.0);
        }

        @Test
        void unreadableWakeupIsContentInvalid() throws Exception {
            connect(options());
            Message ack = fake.callback(WAIT).deliver(wakeup("<notawakeup/>"), WAIT);
            assertEquals("RECEIVE_ERROR", ack.type());
            assertTrue(ack.content().startsWith("CONTENT_INVALID: "), ack.content());
        }

        @Test
        void phaseUpdateIsReportedWithoutTrigger() throws Exception {
            connect(options());
            String content = "<objectdictionary><object name=\"PhaseSpec\"><phase name=\"P\" "
                    + "lasttrigger=\"\"/></object></objectdictionary>";
            assertEquals("RECEIVE_ACCEPT", fake.callback(WAIT).deliver(wakeup(content), WAIT)
                    .type()); // OA-WAKE-8
            Wakeup w = module.nextWakeup(WAIT).orElseThrow();
            assertTrue(w.isPhaseUpdate());
            assertEquals("P", w.phase());
        }

        @Test
        void forwardedMessageIsAcceptedAndQueued() throws Exception {
            connect(options());
            Message fwd = Message.builder("Chat.Line").sender("Other").to("JTest")
                    .content("hi").build();
            assertEquals("RECEIVE_ACCEPT", fake.callback(WAIT).deliver(fwd, WAIT).type());
            assertEquals(fwd.id(), module.nextMessage(WAIT).orElseThrow().message().id());
        }

        @Test
        void noreplyDeliveryIsNotAnswered() throws Exception {
            connect(options());
            FakeServer.Conn cb = fake.callback(WAIT);
            cb.send(Message.builder("Chat.Quiet").noreply(true).build()); // OA-MSG-15
            Message ping = Message.builder("PING").build();
            Message first = cb.deliver(ping, WAIT);
            assertEquals("PING_SUCCESS", first.type());
            assertEquals(ping.id(), first.isresponse());
        }

        @Test
        void oversizedDeliveryIsRefusedBeforeClosing() throws Exception {
            connect(options().maxFrameXml(1000));
            FakeServer.Conn cb = fake.callback(WAIT);
            byte[] header = {'M', 'e', 's', 's', 'a', 'g', 'e', 0, (byte) 0x88, 0x13, 0, 0};
            cb.sendRaw(header); // 5000 bytes announced, the limit is 1000 (OA-LIM-1)
            Message err = cb.replies.poll(5, TimeUnit.SECONDS);
            assertNotNull(err);
            assertEquals("RECEIVE_ERROR", err.type()); // OA-FRAME-7
            assertTrue(err.content().startsWith("FRAME_TOO_LARGE: "), err.content());
            assertEquals("", err.isresponse());
        }

        @Test
        void failingListenerDoesNotStopTheDispatcher() throws Exception {
            AtomicInteger calls = new AtomicInteger();
            connect(options().wakeupListener(w -> {
                if (calls.incrementAndGet() == 1) {
                    throw new IllegalStateException("listener bug");
                }
                woken.add(w);
            }));
            FakeServer.Conn cb = fake.callback(WAIT);
            cb.deliver(wakeup(WAKEUP_CONTENT), WAIT);
            cb.deliver(wakeup(WAKEUP_CONTENT), WAIT);
            assertNotNull(woken.poll(5, TimeUnit.SECONDS));
            Throwable reported = errors.poll(5, TimeUnit.SECONDS);
            assertTrue(reported instanceof IllegalStateException, String.valueOf(reported));
        }
    }

    @Nested
    class Listening {
        @Test
        void deliveriesOnTheBoundPortAreAnswered() throws Exception {
            fake.bindPort = freePort();
            connect(options().listen(true).callback(false));
            assertEquals(fake.bindPort, module.listenPort()); // OA-DELIV-10
            try (Socket s = new Socket(InetAddress.getLoopbackAddress(), module.listenPort())) {
                FrameReader reader = new FrameReader();
                Message ping = Message.builder("PING").sender("WB1").to("JTest").build();
                assertEquals("PING_SUCCESS", exchange(s, reader, ping).type());
                Message w = wakeup(WAKEUP_CONTENT);
                Message ack = exchange(s, reader, w);
                assertEquals("RECEIVE_ACCEPT", ack.type()); // OA-DELIV-2
                assertEquals(w.id(), ack.isresponse());
            }
            assertEquals(DeliveryPath.LISTENER, module.nextWakeup(WAIT).orElseThrow().path());
        }

        Message exchange(Socket s, FrameReader reader, Message m) throws IOException {
            s.getOutputStream().write(new Frame(Frame.Tag.MESSAGE, Codec.encode(m), List.of())
                    .encode());
            InputStream in = s.getInputStream();
            byte[] buf = new byte[4096];
            while (true) {
                Frame f = reader.next();
                if (f != null) {
                    return Codec.decode(f.xml());
                }
                int n = in.read(buf);
                if (n < 0) {
                    throw new AssertionError("closed");
                }
                reader.feed(buf, 0, n);
            }
        }
    }

    @Nested
    class Lifecycle {
        @Test
        void keepaliveIsSentWhenIdle() throws Exception {
            connect(options().keepalive(Duration.ofMillis(200)));
            Message keep = fake.next("KEEPALIVE", WAIT).message(); // OA-KEEP-1
            assertEquals("", keep.sender());
            assertEquals("", keep.to());
        }

        @Test
        void closeEndsRequestsAndWaits() throws Exception {
            connect(options());
            module.close();
            assertThrows(ConnectionClosedException.class, () -> module.post("WB1", "A.B", ""));
            assertEquals(Optional.empty(), module.nextWakeup(Duration.ofSeconds(5)));
            assertFalse(module.isConnected());
            module.close(); // idempotent
        }

        @Test
        void nextWakeupWithAListenerIsMisuse() {
            connect(options().wakeupListener(w -> { }));
            assertThrows(ApiMisuseException.class, () -> module.nextWakeup(Duration.ZERO));
        }
    }

    static int freePort() throws IOException {
        try (ServerSocket s = new ServerSocket(0, 1, InetAddress.getLoopbackAddress())) {
            return s.getLocalPort();
        }
    }
}
