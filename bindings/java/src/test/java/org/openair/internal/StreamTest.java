package org.openair.internal;

import static org.junit.jupiter.api.Assertions.assertArrayEquals;
import static org.junit.jupiter.api.Assertions.assertEquals;
import static org.junit.jupiter.api.Assertions.assertFalse;
import static org.junit.jupiter.api.Assertions.assertThrows;
import static org.junit.jupiter.api.Assertions.assertTrue;

import java.io.IOException;
import java.nio.ByteBuffer;
import java.time.Duration;
import java.util.ArrayList;
import java.util.HashSet;
import java.util.List;
import java.util.Map;
import java.util.Optional;
import java.util.Set;
import java.util.concurrent.BlockingQueue;
import java.util.concurrent.CopyOnWriteArrayList;
import java.util.concurrent.Flow;
import java.util.concurrent.LinkedBlockingQueue;
import java.util.concurrent.TimeUnit;
import org.junit.jupiter.api.AfterEach;
import org.junit.jupiter.api.BeforeEach;
import org.junit.jupiter.api.Test;
import org.junit.jupiter.api.Timeout;
import org.openair.ApiMisuseException;
import org.openair.DataSample;
import org.openair.ErrorCode;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
import org.openair.ReceivedSample;
import org.openair.Registration;
import org.openair.RequestFailedException;
import org.openair.StreamHandle;
import org.openair.StreamInfo;
import org.openair.StreamLock;
import org.openair.StreamSubscription;

/**
 * The stream API against a scripted server: {@link FakeServer} with a small in-memory stream
 * {@code Cam} (type {@code Video.Cam}) that answers the media commands of spec section 11.
 */
@Timeout(value = 20, unit = TimeUnit.SECONDS)
class StreamTest {
    static final Duration WAIT = Duration.ofSeconds(5);

    FakeServer fake;
    Module module;
    final List<DataSample> held = new CopyOnWriteArrayList<>();
    final List<FakeServer.Conn> pushes = new CopyOnWriteArrayList<>();
    final Set<Long> locks = new HashSet<>();
    long nextLock = 1;

    @BeforeEach
    void start() throws IOException {
        fake = new FakeServer();
        fake.advertised = Set.of("noreply", "pipelining", "typed-streams");
        script();
        module = OpenAir.connect(Options.builder("Writer").server("127.0.0.1", fake.port())
                .bind(false).requestTimeout(WAIT).build());
    }

    @AfterEach
    void stop() throws IOException {
        module.close();
        fake.close();
    }

    static Message reply(Message req, String type, String content, List<byte[]> chunks,
            boolean xml) {
        Message.Builder b = Message.builder(type).sender("Cam").to(req.sender())
                .isresponse(req.id()).binary(chunks);
        return (xml ? b.xmlContent(content) : b.content(content)).build();
    }

    synchronized long add(byte[] chunk) {
        DataSample s = SampleCodec.decode(chunk);
        long id = held.size() + 1;
        DataSample stored = s.withParams(Map.of(DataSample.ID, Long.toString(id)));
        held.add(stored);
        notifyAll();
        for (FakeServer.Conn c : pushes) {
            try {
                c.send(Message.builder("DATASAMPLE").sender("Cam").to("Writer")
                        .xmlContent("<datasample/>").binary(List.of(SampleCodec.encode(stored)))
                        .extra(org.openair.Slot.text("dropped", "2")).build());
            } catch (IOException e) {
                throw new IllegalStateException(e);
            }
        }
        return id;
    }

    DataSample byId(long id) {
        return id >= 1 && id <= held.size() ? held.get((int) id - 1) : null;
    }

    void sample(FakeServer.Conn c, Message req, DataSample s) throws IOException {
        if (s == null) {
            c.send(reply(req, "RECEIVE_ERROR", "SAMPLE_UNKNOWN: none", List.of(), false));
        } else {
            c.send(reply(req, "DATASAMPLE", "<datasample/>", List.of(SampleCodec.encode(s)),
                    true));
        }
    }

    void script() {
        var b = fake.behaviours;
        b.put("GET_NAME", (c, r) -> c.send(reply(r, "NAME", "Cam", List.of(), false)));
        b.put("ADD_SAMPLE", (c, r) -> {
            if (r.binaryCount() != 1) {
                c.send(reply(r, "DATA_NOT_ACCEPTED", "SAMPLE_INVALID: chunks", List.of(), false));
                return;
            }
            long id = add(r.binary().get(0));
            if (!r.noreply()) {
                c.send(reply(r, "DATA_ACCEPTED", Long.toString(id), List.of(), false));
            }
        });
        b.put("BinaryM", (c, r) -> c.send(Message.builder("DATA_ACCEPTED").sender("Cam")
                .content(Long.toString(add(r.binary().get(0)))).build())); // empty isresponse
        b.put("ADD_SAMPLES", (c, r) -> {
            StringBuilder ids = new StringBuilder("<collection>");
            for (byte[] chunk : r.binary()) {
                ids.append("<entry>").append(add(chunk)).append("</entry>");
            }
            c.send(reply(r, "DATA_ACCEPTED", ids.append("</collection>").toString(), List.of(),
                    true));
        });
        b.put("GET_SAMPLE_BY_ID", (c, r) -> sample(c, r, byId(Long.parseLong(r.content()))));
        b.put("GET_NEWEST_DATASAMPLE", (c, r) -> sample(c, r, byId(held.size())));
        b.put("GET_OLDEST_DATASAMPLE", (c, r) -> sample(c, r, byId(1)));
        b.put("GET_COUNT", (c, r) -> c.send(reply(r, "COUNT", " " + held.size() + " ",
                List.of(), false)));
        b.put("GET_NEWEST_TIMESTAMP", (c, r) -> c.send(reply(r, "TIMESTAMP",
                "<time sec=\"1795328400\" msec=\"120\"/>", List.of(), true)));
        b.put("GET_INFO", (c, r) -> c.send(reply(r, "INFO", "<streaminfo name=\"Cam\" "
                + "whiteboard=\"WB1\" type=\"Video.Cam\" count=\"" + held.size() + "\" size=\"0\""
                + (held.isEmpty() ? "" : " oldest=\"1\" newest=\"" + held.size() + "\"")
                + " maxsize=\"10485760\" maxcount=\"0\" subscribers=\"" + pushes.size()
                + "\" writers=\"1\" locked=\"0\"/>", List.of(), true)));
        b.put("GET_SAMPLES_BY_TIME", (c, r) -> {
            List<byte[]> chunks = new ArrayList<>();
            StringBuilder xml = new StringBuilder("<objectcollection>");
            for (DataSample s : held) {
                chunks.add(SampleCodec.encode(s));
                xml.append("<object><datasample/></object>");
            }
            c.send(reply(r, "DATASAMPLES", xml.append("</objectcollection>").toString(), chunks,
                    true));
        });
        b.put("SEARCH_SAMPLES", b.get("GET_SAMPLES_BY_TIME"));
        b.put("LOCK_SAMPLES", (c, r) -> {
            long id;
            synchronized (this) {
                id = nextLock++;
                locks.add(id);
            }
            c.send(reply(r, "LOCKED", Long.toString(id), List.of(), false));
        });
        b.put("UNLOCK_SAMPLES", (c, r) -> {
            boolean known;
            synchronized (this) {
                known = locks.remove(Long.parseLong(r.content()));
            }
            c.send(known ? reply(r, "RECEIVE_ACCEPT", "", List.of(), false)
                    : reply(r, "RECEIVE_ERROR", "LOCK_UNKNOWN: " + r.content(), List.of(), false));
        });
        b.put("WAIT_FOR_FIRST_AFTERID", (c, r) -> {
            long after = Long.parseLong(r.content());
            long timeout = Long.parseLong(r.type().split(" ")[1]);
            long deadline = System.nanoTime() + TimeUnit.MILLISECONDS.toNanos(timeout);
            DataSample found;
            synchronized (this) {
                while ((found = byId(after + 1)) == null && System.nanoTime() < deadline) {
                    try {
                        wait(Math.max(1, TimeUnit.NANOSECONDS.toMillis(
                                deadline - System.nanoTime())));
                    } catch (InterruptedException e) {
                        return;
                    }
                }
            }
            sample(c, r, found);
        });
        b.put("GET_STREAMS", (c, r) -> c.send(Message.builder("STREAMS").sender("CNS")
                .to(r.sender()).isresponse(r.id()).xmlContent("<streams><streaminfo name=\"Cam\""
                        + " whiteboard=\"WB1\" count=\"0\" size=\"0\"/></streams>").build()));
    }

    static DataSample sample(String text, Map<String, String> params) {
        return DataSample.of(text.getBytes(java.nio.charset.StandardCharsets.US_ASCII))
                .withParams(params);
    }

    static String text(DataSample s) {
        return new String(s.payloadBytes(), java.nio.charset.StandardCharsets.US_ASCII);
    }

    @Test
    void addAndReadBack() {
        StreamHandle cam = module.stream("Video.Cam");
        assertEquals("Cam", cam.name()); // GET_NAME on the handle's own connection
        long a = cam.add(sample("one", Map.of("camera", "left", DataSample.SEQ, "7")));
        List<Long> many = cam.addAll(List.of(sample("two", Map.of()), sample("three", Map.of())));
        assertEquals(List.of(a + 1, a + 2), many);
        DataSample got = cam.get(a);
        assertEquals("one", text(got));
        assertEquals(Optional.of("left"), got.param("camera"));
        assertEquals(a, got.id().getAsLong());
        assertTrue(got.payload().isReadOnly());
        assertEquals("three", text(cam.newest()));
        assertEquals("one", text(cam.oldest()));
        assertEquals(3, cam.count());
        assertEquals(1795328400120L, cam.newestTimestamp());
        assertEquals(List.of("one", "two", "three"), cam.between(0, 1).stream()
                .map(StreamTest::text).toList());
        StreamInfo info = cam.info();
        assertEquals("Video.Cam", info.type());
        assertEquals(3, info.newest().getAsLong());
        assertSame(cam, module.stream("Video.Cam"));
    }

    static void assertSame(Object a, Object b) {
        org.junit.jupiter.api.Assertions.assertSame(a, b);
    }

    @Test
    void aFailureReplyNamesItsCondition() {
        StreamHandle cam = module.stream("Cam");
        RequestFailedException e = assertThrows(RequestFailedException.class, () -> cam.get(42));
        assertEquals(Optional.of(ErrorCode.SAMPLE_UNKNOWN), e.condition());
    }

    @Test
    void binaryAndPipelinedWritesAreAnsweredInOrder() throws Exception {
        StreamHandle cam = module.stream("Cam");
        long first = cam.submit(sample("b0", Map.of()), true).get(5, TimeUnit.SECONDS);
        List<Long> ids = cam.addPipelined(List.of(sample("p1", Map.of()), sample("p2", Map.of()),
                sample("p3", Map.of())));
        assertEquals(List.of(first + 1, first + 2, first + 3), ids);
        FakeServer.Received binary = fake.find("BinaryM", WAIT);
        assertEquals(org.openair.internal.Frame.Tag.BINARY, binary.tag());
        assertEquals("b0", text(SampleCodec.decode(binary.message().binary().get(0))));
    }

    @Test
    void aLargePayloadTravelsFromTheCallersBuffer() {
        byte[] big = new byte[200_000];
        for (int i = 0; i < big.length; i++) {
            big[i] = (byte) (i * 31);
        }
        StreamHandle cam = module.stream("Cam");
        long id = cam.add(DataSample.of(ByteBuffer.wrap(big)));
        assertArrayEquals(big, cam.get(id).payloadBytes());
    }

    @Test
    void noreplyWritesNeedNoAnswer() throws Exception {
        StreamHandle cam = module.stream("Cam");
        cam.addNoReply(sample("quiet", Map.of()));
        FakeServer.Received r = fake.find("ADD_SAMPLE", WAIT);
        assertTrue(r.message().noreply()); // advertised, so declared (OA-MSG-15)
        assertEquals(1, cam.count()); // the connection is still in step
    }

    @Test
    void aWaitReturnsTheNextSampleOrEmpty() throws Exception {
        StreamHandle cam = module.stream("Cam");
        long a = cam.add(sample("first", Map.of()));
        assertEquals(Optional.empty(), cam.waitAfterId(a, Duration.ofMillis(50), false));
        BlockingQueue<Optional<DataSample>> got = new LinkedBlockingQueue<>();
        Thread waiter = new Thread(() -> got.add(cam.waitAfterId(a, WAIT, false)));
        waiter.start();
        fake.find("WAIT_FOR_FIRST_AFTERID 5000", WAIT); // the wait is at the server
        cam.add(sample("second", Map.of())); // the handle's own connection is not blocked
        assertEquals("second", text(got.poll(5, TimeUnit.SECONDS).orElseThrow()));
        waiter.join();
    }

    @Test
    void aLockIsReleasedByTryWithResources() throws Exception {
        StreamHandle cam = module.stream("Cam");
        cam.add(sample("x", Map.of()));
        long id;
        try (StreamLock lock = cam.lock(1, 1)) {
            id = lock.lockId();
            assertEquals("1-1", fake.find("LOCK_SAMPLES", WAIT).message().content());
        }
        assertEquals(Long.toString(id), fake.find("UNLOCK_SAMPLES", WAIT).message().content());
        RequestFailedException e = assertThrows(RequestFailedException.class,
                () -> cam.unlock(id)); // released already
        assertEquals(Optional.of(ErrorCode.LOCK_UNKNOWN), e.condition());
        assertThrows(ApiMisuseException.class, () -> cam.lock(5, 2));
    }

    @Test
    void lockAndSearchNeedTypedStreams() throws Exception {
        module.close();
        fake.advertised = Set.of("noreply");
        module = OpenAir.connect(Options.builder("Writer").server("127.0.0.1", fake.port())
                .bind(false).build());
        StreamHandle cam = module.stream("Cam");
        assertThrows(ApiMisuseException.class, () -> cam.lock(1, 2)); // OA-GEN-2
        assertThrows(ApiMisuseException.class, () -> cam.search(null, null, Map.of(), 0));
    }

    @Test
    void searchSendsASampleSearch() throws Exception {
        StreamHandle cam = module.stream("Cam");
        cam.add(sample("x", Map.of("camera", "left")));
        assertEquals(1, cam.search(1000L, null, Map.of("camera", "le*"), 3).size());
        assertEquals("<samplesearch><afterTime>1000</afterTime><param name=\"camera\">le*</param>"
                + "<latest>3</latest></samplesearch>",
                fake.find("SEARCH_SAMPLES", WAIT).message().content());
    }

    void acceptPushes() {
        Thread t = new Thread(() -> {
            try {
                FakeServer.Conn c = fake.callback(WAIT);
                assertEquals("Cam", c.notification.to());
                pushes.add(c);
            } catch (InterruptedException e) {
                Thread.currentThread().interrupt();
            }
        });
        t.setDaemon(true);
        t.start();
    }

    @Test
    void aPushSubscriptionReceivesEverySampleAndAcknowledgesIt() throws Exception {
        StreamHandle cam = module.stream("Cam");
        acceptPushes();
        try (StreamSubscription sub = cam.subscribe(10)) { // returns once GET_INFO counts it
            assertEquals(1, pushes.size());
            cam.add(sample("pushed", Map.of()));
            ReceivedSample got = sub.next(WAIT).orElseThrow();
            assertEquals("Cam", got.stream());
            assertEquals("pushed", text(got.sample()));
            assertEquals(2, got.dropped());
            Message ack = pushes.get(0).replies.poll(5, TimeUnit.SECONDS);
            assertEquals("RECEIVE_ACCEPT", ack.type()); // OA-STREAM-8
            assertEquals(1, sub.received());
            assertEquals(2, sub.dropped());
        }
    }

    @Test
    void aListenerGetsTheSamplesOnItsOwnThread() throws Exception {
        StreamHandle cam = module.stream("Cam");
        acceptPushes();
        BlockingQueue<String> got = new LinkedBlockingQueue<>();
        try (StreamSubscription sub = cam.subscribe(
                s -> got.add(text(s.sample()) + "@" + Thread.currentThread().getName()))) {
            cam.add(sample("a", Map.of()));
            cam.add(sample("b", Map.of()));
            assertTrue(got.poll(5, TimeUnit.SECONDS).startsWith("a@openair-Writer-samples-"));
            assertTrue(got.poll(5, TimeUnit.SECONDS).startsWith("b@"));
            assertThrows(ApiMisuseException.class, () -> sub.next(Duration.ZERO));
        }
    }

    @Test
    void aPublisherHonoursDemand() throws Exception {
        StreamHandle cam = module.stream("Cam");
        acceptPushes();
        BlockingQueue<String> got = new LinkedBlockingQueue<>();
        BlockingQueue<Flow.Subscription> subs = new LinkedBlockingQueue<>();
        cam.publisher().subscribe(new Flow.Subscriber<ReceivedSample>() {
            @Override
            public void onSubscribe(Flow.Subscription s) {
                subs.add(s);
            }

            @Override
            public void onNext(ReceivedSample item) {
                got.add(text(item.sample()));
            }

            @Override
            public void onError(Throwable t) {
                got.add("error " + t);
            }

            @Override
            public void onComplete() {
                got.add("complete");
            }
        });
        Flow.Subscription s = subs.poll(5, TimeUnit.SECONDS);
        cam.add(sample("one", Map.of()));
        cam.add(sample("two", Map.of()));
        s.request(1);
        assertEquals("one", got.poll(5, TimeUnit.SECONDS));
        FakeServer.Conn push = pushes.get(0);
        push.replies.poll(5, TimeUnit.SECONDS);
        push.replies.poll(5, TimeUnit.SECONDS); // "two" is buffered and acknowledged…
        assertTrue(got.isEmpty()); // …but not handed over without demand
        s.request(1);
        assertEquals("two", got.poll(5, TimeUnit.SECONDS));
        s.cancel();
    }

    @Test
    void aRefusedSubscriptionFails() throws Exception {
        StreamHandle nowhere = module.stream("Nowhere");
        fake.behaviours.put("GET_INFO", (c, r) -> c.send(reply(r, "INFO",
                "<streaminfo name=\"Nowhere\" subscribers=\"0\"/>", List.of(), true)));
        Thread t = new Thread(() -> {
            try {
                FakeServer.Conn c = fake.callback(WAIT);
                c.send(Message.builder("RECEIVE_ERROR").sender("CNS")
                        .content("STREAM_UNKNOWN: Nowhere").build());
            } catch (Exception e) {
                throw new IllegalStateException(e);
            }
        });
        t.start();
        RequestFailedException e = assertThrows(RequestFailedException.class,
                () -> nowhere.subscribe(5));
        assertEquals(Optional.of(ErrorCode.STREAM_UNKNOWN), e.condition());
        t.join();
    }

    @Test
    void listStreamsAsksCns() {
        List<StreamInfo> all = module.listStreams();
        assertEquals(1, all.size());
        assertEquals("Cam", all.get(0).name());
        assertFalse(all.get(0).oldest().isPresent());
    }

    @Test
    void aRegistrationSubscribesToInputStreams() throws Exception {
        module.close();
        module = OpenAir.connect(Options.builder("Reader").server("127.0.0.1", fake.port())
                .listen(false).announce(false).build());
        module.subscribe(new Registration(List.of(), List.of(), false, List.of("Video.*")));
        String content = fake.find("AIR.Subscribe", WAIT).message().content();
        assertEquals("<module name=\"Reader\"><inputstream alias=\"Video.*\" source=\"Video.*\"/>"
                + "</module>", content);
        FakeServer.Conn callback = fake.callback(WAIT);
        DataSample s = sample("frame", Map.of(DataSample.ID, "5"));
        Message ack = callback.deliver(Message.builder("DATASAMPLE").sender("Cam").to("Reader")
                .xmlContent("<datasample/>").binary(List.of(SampleCodec.encode(s))).build(), WAIT);
        assertEquals("RECEIVE_ACCEPT", ack.type()); // OA-STREAM-14, OA-DELIV-4
        ReceivedSample got = module.nextSample(WAIT).orElseThrow();
        assertEquals("frame", text(got.sample()));
        assertEquals(5, got.sample().id().getAsLong());
        Message bad = callback.deliver(Message.builder("DATASAMPLE").sender("Cam").to("Reader")
                .xmlContent("<datasample/>").binary(List.of(new byte[] {1, 0})).build(), WAIT);
        assertEquals("RECEIVE_ERROR", bad.type());
        assertTrue(bad.content().startsWith("SAMPLE_INVALID"), bad.content());
    }
}
