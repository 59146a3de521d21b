import java.time.Duration;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;
import org.openair.Registration;
import org.openair.RetrieveSpec;
import org.openair.Trigger;
import org.openair.Wakeup;

/**
 * Reader: binds as "Reader", registers a trigger on WB1 (with a retrieve of the last two posts)
 * and prints every wakeup until it has seen COUNT of them (default 3).
 *
 * <p>Run: {@code java -cp target/openair.jar examples/Reader.java [HOST PORT [COUNT]]}
 *
 * <p>Threading: wakeups arrive on the module's dispatcher thread; this program hands them to the
 * main thread through {@link Module#nextWakeup(Duration)} instead (no listener is set).
 */
public final class Reader {
    public static void main(String[] args) {
        String host = args.length > 0 ? args[0] : "127.0.0.1";
        int port = args.length > 1 ? Integer.parseInt(args[1]) : 10000;
        int count = args.length > 2 ? Integer.parseInt(args[2]) : 3;
        Options options = Options.builder("Reader").server(host, port).build();
        try (Module reader = OpenAir.connect(options)) {
            System.out.printf("bound (port %d, legacy %b, extensions %s)%n",
                    reader.boundPort(), reader.legacy(), reader.extensions());
            reader.subscribe(new Registration(
                    java.util.List.of(Trigger.on("WB1", "Test.Ping.*")),
                    java.util.List.of(RetrieveSpec.of("WB1", "Test.Ping.*", 2)), false));
            int seen = 0;
            while (seen < count) {
                Wakeup w = reader.nextWakeup(Duration.ofSeconds(30)).orElse(null);
                if (w == null) {
                    System.out.println("no wakeup within 30 s");
                    return;
                }
                if (w.isPhaseUpdate()) {
                    System.out.println("phase update: " + w.phase());
                    continue;
                }
                Message m = w.trigger();
                System.out.printf("woken by %s from %s: '%s' (trigger %s, %d retrieved, via %s)%n",
                        m.type(), m.sender(), m.content(), w.lasttrigger(), w.retrieved().size(),
                        w.path());
                seen++;
            }
        }
    }
}
