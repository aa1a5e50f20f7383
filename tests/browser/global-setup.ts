// global-setup.ts -- one irpd + agent (PLC + robot cell; viser and meshcat views) for the whole browser suite;
// its address and tokens reach the tests through INDUROP_SERVER.
import { startServer, stopServer } from "./server";

export default async function globalSetup(): Promise<() => Promise<void>> {
  const server = await startServer();
  process.env.INDUROP_SERVER = JSON.stringify(server);
  return () => stopServer(server);
}
