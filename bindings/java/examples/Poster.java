import java.util.ArrayList;
import java.util.List;
import org.openair.Message;
import org.openair.Module;
import org.openair.OpenAir;
import org.openair.Options;

/**
 * Poster: a plain client (no BIND) that posts COUNT messages of type Test.Ping.A to WB1, one with
 * {@code post} and the rest with {@code postAll} (pipelined when the server advertises it).
 *
 * <p>Run: {@code java -cp target/openair.jar examples/Poster.java [HOST PORT [COUNT]]}
 *
 * <p>Threading: every call blocks the calling thread until the server acknowledged the post.
 */
public final class Poster {
    public static void main(String[] args) {
        String host = args.length > 0 ? args[0] : "127.0.0.1";
        int port = args.length > 1 ? Integer.parseInt(args[1]) : 10000;
        int count = args.length > 2 ? Integer.parseInt(args[2]) : 3;
        Options options = Options.builder("Poster").server(host, port).bind(false).build();
        try (Module poster = OpenAir.connect(options)) {
            Message first = poster.post("WB1", "Test.Ping.A", "hello ping 1");
            System.out.println("posted " + first.id() + " at " + first.posted());
            List<Message> rest = new ArrayList<>();
            for (int i = 2; i <= count; i++) {
                rest.add(Message.builder("Test.Ping.A").to("WB1").content("hello ping " + i)
                        .build());
            }
            for (Message m : poster.postAll(rest)) {
                System.out.println("posted " + m.id() + " at " + m.posted());
            }
        }
    }
}
